//! The committed example programs of `docs/controller.md` (`docs/controller/`): ten targets
//! of the KR1000 and of the UR10, each the nominal forward kinematics of a joint vector in
//! the limits, written in every format. Shared by `examples/programs/main.rs` (which writes the
//! files) and the golden test (which checks the committed files are these bytes).

use std::path::Path;

use controller::{Format, Target};
use kinematics::Robot;

/// The robots: (file stem in `docs/controller/`, robot file, program name, joint sets in
/// model degrees). The KR1000's sets cover every Status the arm reaches in its limits
/// (forward and overhead, elbow up and beyond stretched, A5 of either sign).
pub const ROBOTS: [(&str, &str, &str, [[f64; 6]; 10]); 2] = [
    (
        "kr1000",
        "scenarios/robots/kr1000-titan.json",
        "kincal_kr1000",
        [
            [0.0, 0.0, 0.0, 0.0, 45.0, 0.0],
            [30.0, 20.0, -10.0, 15.0, 60.0, -30.0],
            [-45.0, 35.0, -30.0, -20.0, 75.0, 40.0],
            [60.0, 10.0, 20.0, 90.0, -50.0, 120.0],
            [-90.0, 45.0, -60.0, 0.0, 30.0, -90.0],
            [120.0, 60.0, -90.0, -45.0, 80.0, 10.0],
            [-20.0, -30.0, -150.0, 30.0, 40.0, 200.0],
            [10.0, -35.0, -170.0, -60.0, -70.0, -200.0],
            [75.0, 80.0, 40.0, 170.0, 100.0, 0.0],
            [-130.0, 5.0, -45.0, -170.0, -30.0, 300.0],
        ],
    ),
    (
        "ur10",
        "scenarios/robots/ur10.json",
        "kincal_ur10",
        [
            [0.0, -90.0, 90.0, -90.0, -90.0, 0.0],
            [30.0, -60.0, 80.0, -110.0, -90.0, 45.0],
            [-45.0, -120.0, 100.0, -70.0, -80.0, -30.0],
            [90.0, -45.0, -60.0, -160.0, 90.0, 0.0],
            [-90.0, -100.0, 60.0, -50.0, 100.0, 180.0],
            [135.0, -80.0, 110.0, -120.0, -45.0, -90.0],
            [-150.0, -70.0, -90.0, -20.0, 60.0, 270.0],
            [60.0, -130.0, 45.0, -90.0, -120.0, -180.0],
            [-20.0, -30.0, 120.0, -180.0, 80.0, 10.0],
            [180.0, -95.0, 75.0, -70.0, -95.0, 90.0],
        ],
    ),
];

/// The targets of one robot: `t01` … `t10`, the joints and their nominal TCP pose.
pub fn targets(robot: &Robot, sets: &[[f64; 6]]) -> Vec<Target> {
    sets.iter()
        .enumerate()
        .map(|(k, q)| {
            let (position_mm, orientation) = controller::tcp_pose(robot, q);
            Target {
                name: format!("t{:02}", k + 1),
                joints_deg: q.to_vec(),
                position_mm,
                orientation_wxyz: Some(orientation),
            }
        })
        .collect()
}

/// Every example file: (path relative to the repository root, bytes).
pub fn files(root: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (stem, robot_file, program, sets) in ROBOTS {
        let robot = Robot::from_file(&root.join(robot_file)).expect("committed robot file");
        let decl = controller::declare(&robot, &targets(&robot, &sets)).expect("in the limits");
        let header = [
            format!(
                "kincal docs/controller.md example: 10 targets of {robot_file} ({}),",
                robot.name()
            ),
            "the nominal TCP pose of each joint vector; axes by the file's controller mapping"
                .to_owned(),
        ];
        for format in Format::ALL {
            let text = controller::write(format, program, &header, &decl).expect("valid name");
            out.push((
                format!("docs/controller/{stem}.{}", format.extension()),
                text,
            ));
        }
    }
    out
}
