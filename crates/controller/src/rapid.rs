//! ABB RAPID: a module of robtarget and jointtarget declarations (crate docs, "Conventions
//! and sources").

use crate::number::{At, DEG, MM, QUAT, join, opening, read_lines};
use crate::{AXES, ControllerError, Declaration, ReadTarget, abb_confdata};

/// Six external axes that are not there.
const NO_EXTERNAL: &str = "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]";

/// `MODULE program`, the header as `!` comments, per target a `! target` comment, a
/// `CONST robtarget pk` and a `CONST jointtarget jk` (k from 1), a `main` moving to the
/// joint targets in order, `ENDMODULE`.
pub fn write(program: &str, header: &[String], declarations: &[Declaration]) -> String {
    let mut out = opening(&format!("MODULE {program}"), "  !", header);
    for (k, d) in declarations.iter().enumerate() {
        let k = k + 1;
        let cf = abb_confdata(&d.config, &d.axes_deg);
        out += &format!("  ! target {}\n", d.name);
        out += &format!(
            "  CONST robtarget p{k}:=[[{}],[{}],[{},{},{},{}],{NO_EXTERNAL}];\n",
            join(&d.position_mm, MM, ","),
            join(&d.orientation_wxyz, QUAT, ","),
            cf[0],
            cf[1],
            cf[2],
            cf[3]
        );
        out += &format!(
            "  CONST jointtarget j{k}:=[[{}],{NO_EXTERNAL}];\n",
            join(&d.axes_deg, DEG, ",")
        );
    }
    out += "  PROC main()\n";
    for k in 1..=declarations.len() {
        out += &format!("    MoveAbsJ j{k}\\NoEOffs, v100, fine, tool0;\n");
    }
    out += "  ENDPROC\nENDMODULE\n";
    out
}

/// A RAPID aggregate: a number (as written) or a bracketed list.
#[derive(Debug)]
enum Node {
    Num(String),
    List(Vec<Node>),
}

/// Parses one aggregate from `s` at `*i`.
fn node(s: &[u8], i: &mut usize) -> Option<Node> {
    while *i < s.len() && s[*i].is_ascii_whitespace() {
        *i += 1;
    }
    if *i < s.len() && s[*i] == b'[' {
        *i += 1;
        let mut items = Vec::new();
        loop {
            items.push(node(s, i)?);
            while *i < s.len() && s[*i].is_ascii_whitespace() {
                *i += 1;
            }
            match s.get(*i)? {
                b',' => *i += 1,
                b']' => {
                    *i += 1;
                    return Some(Node::List(items));
                }
                _ => return None,
            }
        }
    }
    let start = *i;
    while *i < s.len() && !matches!(s[*i], b',' | b']' | b'[') {
        *i += 1;
    }
    let text = std::str::from_utf8(&s[start..*i]).ok()?.trim().to_owned();
    (!text.is_empty()).then_some(Node::Num(text))
}

/// The numbers of a list node of `N` numbers, named `field[k]`.
fn numbers<const N: usize>(at: At<'_>, field: &str, n: &Node) -> Result<[f64; N], ControllerError> {
    let Node::List(items) = n else {
        return Err(at.err(format!("{field}: a list [..] is expected")));
    };
    let mut parts = Vec::with_capacity(items.len());
    for (k, item) in items.iter().enumerate() {
        let Node::Num(t) = item else {
            return Err(at.err(format!("{field}[{k}]: a number is expected")));
        };
        parts.push(t.as_str());
    }
    at.values(field, &parts)
}

/// The robtarget and jointtarget declarations (CONST, PERS or VAR) of a module; other
/// lines are skipped.
pub fn read(text: &str, source_name: &str) -> Result<Vec<ReadTarget>, ControllerError> {
    read_lines(text, source_name, '!', |at, line, c| {
        let mut words = line.splitn(3, char::is_whitespace);
        let storage = words.next().unwrap_or("");
        if !["CONST", "PERS", "VAR"].contains(&storage) {
            return Ok(());
        }
        let kind = words.next().unwrap_or("");
        let robtarget = kind == "robtarget";
        if !robtarget && kind != "jointtarget" {
            return Ok(());
        }
        let rest = words.next().unwrap_or("");
        let (var, value) = rest
            .split_once(":=")
            .ok_or_else(|| at.err(format!("{kind} without `:=`")))?;
        let var = var.trim();
        let value = value
            .trim()
            .strip_suffix(';')
            .ok_or_else(|| at.err(format!("{var}: the declaration does not end in `;`")))?;
        let mut pos = 0;
        let bytes = value.as_bytes();
        let parsed = node(bytes, &mut pos)
            .filter(|_| bytes[pos..].iter().all(u8::is_ascii_whitespace))
            .ok_or_else(|| at.err(format!("{var}: the value is not a RAPID aggregate [..]")))?;
        let Node::List(parts) = parsed else {
            return Err(at.err(format!("{var}: the value is not a RAPID aggregate [..]")));
        };
        if robtarget {
            if parts.len() != 4 {
                return Err(at.err(format!(
                    "{var}: a robtarget has 4 parts [trans, rot, robconf, extax], this one {}",
                    parts.len()
                )));
            }
            let trans = numbers::<3>(at, &format!("{var}.trans"), &parts[0])?;
            let rot = numbers::<4>(at, &format!("{var}.rot"), &parts[1])?;
            let cf = numbers::<4>(at, &format!("{var}.robconf"), &parts[2])?;
            numbers::<6>(at, &format!("{var}.extax"), &parts[3])?;
            if cf.iter().any(|v| v.fract() != 0.0) {
                return Err(at.err(format!("{var}.robconf: quadrants are integers")));
            }
            let norm = rot.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-4 {
                return Err(at.err(format!(
                    "{var}.rot: norm {norm} is not that of a unit quaternion"
                )));
            }
            let t = c.target_for(var, |t| t.position_mm.is_some());
            t.position_mm = Some(trans);
            t.orientation_wxyz = Some(rot.map(|v| v / norm));
            t.abb_confdata = Some(cf.map(|v| v as i32));
        } else {
            if parts.len() != 2 {
                return Err(at.err(format!(
                    "{var}: a jointtarget has 2 parts [robax, extax], this one {}",
                    parts.len()
                )));
            }
            let axes = numbers::<AXES>(at, &format!("{var}.robax"), &parts[0])?;
            numbers::<6>(at, &format!("{var}.extax"), &parts[1])?;
            c.target_for(var, |t| t.axes_deg.is_some()).axes_deg = Some(axes);
        }
        Ok(())
    })
}
