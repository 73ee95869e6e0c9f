//! Universal Robots URScript: a program of pose and joint declarations (crate docs,
//! "Conventions and sources").

use measurements::{quaternion_to_rotvec, rotvec_to_quaternion};

use crate::number::{M, RAD, join, opening, read_lines};
use crate::{AXES, ControllerError, Declaration, ReadTarget};

/// `def program():`, the header as `#` comments, per target a `# target` comment,
/// `global pk = p[x, y, z, rx, ry, rz]` (m, rad) and `global qk = [q1, …, q6]` (rad), the
/// `movej` to each joint target in order, `end`.
pub fn write(program: &str, header: &[String], declarations: &[Declaration]) -> String {
    let mut out = opening(&format!("def {program}():"), "  #", header);
    for (k, d) in declarations.iter().enumerate() {
        let k = k + 1;
        let mut pose = [0.0; 6];
        for (p, mm) in pose.iter_mut().zip(d.position_mm) {
            *p = mm / 1000.0;
        }
        pose[3..].copy_from_slice(&quaternion_to_rotvec(d.orientation_wxyz));
        let q = d.axes_deg.map(f64::to_radians);
        out += &format!("  # target {}\n", d.name);
        out += &format!(
            "  global p{k} = p[{}, {}]\n",
            join(&pose[..3], M, ", "),
            join(&pose[3..], RAD, ", ")
        );
        out += &format!("  global q{k} = [{}]\n", join(&q, RAD, ", "));
    }
    for k in 1..=declarations.len() {
        out += &format!("  movej(q{k}, a=0.5, v=0.25)\n");
    }
    out += "end\n";
    out
}

/// The pose (`p[…]`) and joint (`[…]`, six numbers) assignments of a program, `global` or
/// not; other lines are skipped.
pub fn read(text: &str, source_name: &str) -> Result<Vec<ReadTarget>, ControllerError> {
    read_lines(text, source_name, '#', |at, line, c| {
        let line = line.strip_prefix("global ").unwrap_or(line);
        let Some((var, value)) = line.split_once('=') else {
            return Ok(());
        };
        let var = var.trim();
        if var.is_empty()
            || !var
                .chars()
                .all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
        {
            return Ok(());
        }
        let value = value.trim();
        if let Some(body) = value.strip_prefix("p[").and_then(|b| b.strip_suffix(']')) {
            let v = at.numbers::<6>(&format!("{var} (pose)"), body)?;
            let t = c.target_for(var, |t| t.position_mm.is_some());
            t.position_mm = Some([v[0] * 1000.0, v[1] * 1000.0, v[2] * 1000.0]);
            t.orientation_wxyz = Some(rotvec_to_quaternion([v[3], v[4], v[5]]));
        } else if let Some(body) = value.strip_prefix('[').and_then(|b| b.strip_suffix(']')) {
            let q = at.numbers::<AXES>(&format!("{var} (joints)"), body)?;
            c.target_for(var, |t| t.axes_deg.is_some()).axes_deg = Some(q.map(f64::to_degrees));
        }
        Ok(())
    })
}
