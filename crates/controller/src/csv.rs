//! CSV: one row a target, `target,a1_deg…a6_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz` (controller
//! axis values, the Cartesian target in the robot's base frame).

use crate::number::{At, DEG, MM, QUAT, join};
use crate::{AXES, ControllerError, Declaration, ReadTarget};

/// The header row.
const HEADER: &str = "target,a1_deg,a2_deg,a3_deg,a4_deg,a5_deg,a6_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz";

/// The header lines as `#` comments, the header row, one row a target (a name with a comma
/// or quote, or starting with `#`, is quoted, quotes doubled).
pub fn write(header: &[String], declarations: &[Declaration]) -> String {
    let mut out: String = header.iter().map(|h| format!("# {h}\n")).collect();
    out += HEADER;
    out.push('\n');
    for d in declarations {
        let name = if d.name.contains([',', '"']) || d.name.starts_with('#') {
            format!("\"{}\"", d.name.replace('"', "\"\""))
        } else {
            d.name.clone()
        };
        out += &format!(
            "{name},{},{},{}\n",
            join(&d.axes_deg, DEG, ","),
            join(&d.position_mm, MM, ","),
            join(&d.orientation_wxyz, QUAT, ",")
        );
    }
    out
}

/// The rows of a CSV written by [`write`] (comments and blank lines skipped, the header
/// row checked).
pub fn read(text: &str, source_name: &str) -> Result<Vec<ReadTarget>, ControllerError> {
    let mut out = Vec::new();
    let mut header_seen = false;
    for (i, raw) in text.lines().enumerate() {
        let at = At {
            source_name,
            line: i + 1,
        };
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if !header_seen {
            if line != HEADER {
                return Err(at.err(format!("the header row must be `{HEADER}`")));
            }
            header_seen = true;
            continue;
        }
        let (name, rest) = if let Some(quoted) = line.strip_prefix('"') {
            let mut name = String::new();
            let mut chars = quoted.char_indices();
            let mut end = None;
            while let Some((k, ch)) = chars.next() {
                if ch == '"' {
                    if quoted[k + 1..].starts_with('"') {
                        name.push('"');
                        chars.next();
                    } else {
                        end = Some(k + 1);
                        break;
                    }
                } else {
                    name.push(ch);
                }
            }
            let end = end.ok_or_else(|| at.err("target: the quoted name is not closed"))?;
            let rest = quoted[end..]
                .strip_prefix(',')
                .ok_or_else(|| at.err("target: a comma must follow the quoted name"))?;
            (name, rest)
        } else {
            let (n, r) = line
                .split_once(',')
                .ok_or_else(|| at.err("a row has 14 columns, this one 1"))?;
            (n.to_owned(), r)
        };
        let v = at.numbers::<13>("a1_deg..qz", rest)?;
        let mut axes = [0.0; AXES];
        axes.copy_from_slice(&v[..AXES]);
        out.push(ReadTarget {
            name,
            axes_deg: Some(axes),
            position_mm: Some([v[6], v[7], v[8]]),
            orientation_wxyz: Some([v[9], v[10], v[11], v[12]]),
            ..Default::default()
        });
    }
    Ok(out)
}
