//! KUKA KRL: a `.dat` of E6POS and E6AXIS declarations (crate docs, "Conventions and
//! sources").

use measurements::EulerConvention;

use crate::number::{At, DEG, MM, fixed, opening, read_lines};
use crate::{ControllerError, Declaration, ReadTarget, kuka_status, kuka_turn};

/// The external axes of a six-axis arm without any: `E1 0.0,…,E6 0.0`.
const NO_EXTERNAL: &str = "E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0";

/// `DEFDAT program PUBLIC`, the header as comments, per target a `; target` comment, an
/// E6POS `XPk` and an E6AXIS `XAk` (k from 1), `ENDDAT`.
pub fn write(program: &str, header: &[String], declarations: &[Declaration]) -> String {
    let mut out = opening(&format!("DEFDAT {program} PUBLIC"), ";", header);
    for (k, d) in declarations.iter().enumerate() {
        let k = k + 1;
        let [x, y, z] = d.position_mm;
        let [a, b, c] = EulerConvention::KUKA_ABC.angles_deg(d.orientation_wxyz);
        out += &format!("; target {}\n", d.name);
        out += &format!(
            "DECL E6POS XP{k}={{X {},Y {},Z {},A {},B {},C {},S {},T {},{NO_EXTERNAL}}}\n",
            fixed(x, MM),
            fixed(y, MM),
            fixed(z, MM),
            fixed(a, DEG),
            fixed(b, DEG),
            fixed(c, DEG),
            kuka_status(&d.config, &d.axes_deg),
            kuka_turn(&d.axes_deg),
        );
        let axes: Vec<String> = d
            .axes_deg
            .iter()
            .enumerate()
            .map(|(i, v)| format!("A{} {}", i + 1, fixed(*v, DEG)))
            .collect();
        out += &format!("DECL E6AXIS XA{k}={{{},{NO_EXTERNAL}}}\n", axes.join(","));
    }
    out += "ENDDAT\n";
    out
}

/// The fields `KEY value` of a structure literal `{…}`, keys upper case, in order.
fn fields(at: At<'_>, body: &str) -> Result<Vec<(String, String)>, ControllerError> {
    let mut out: Vec<(String, String)> = Vec::new();
    for part in body.split(',') {
        let part = part.trim();
        let Some((key, value)) = part.split_once(char::is_whitespace) else {
            return Err(at.err(format!("{part:?} is not a field `NAME value`")));
        };
        let key = key.to_ascii_uppercase();
        if out.iter().any(|(k, _)| *k == key) {
            return Err(at.err(format!("field {key} is given twice")));
        }
        out.push((key, value.trim().to_owned()));
    }
    Ok(out)
}

/// The type (upper case) and the rest of a `DECL [GLOBAL] TYPE rest` line.
fn declaration(line: &str) -> Option<(String, &str)> {
    let (first, rest) = line.split_once(char::is_whitespace)?;
    if !first.eq_ignore_ascii_case("DECL") {
        return None;
    }
    let mut rest = rest.trim_start();
    let (mut kind, mut tail) = rest.split_once(char::is_whitespace)?;
    if kind.eq_ignore_ascii_case("GLOBAL") {
        rest = tail.trim_start();
        (kind, tail) = rest.split_once(char::is_whitespace)?;
    }
    Some((kind.to_ascii_uppercase(), tail))
}

/// A Status or Turn value: decimal, or KRL's binary `'B0110'`.
fn bits(at: At<'_>, field: &str, v: &str) -> Result<u8, ControllerError> {
    let parsed = match v.strip_prefix("'B").and_then(|r| r.strip_suffix('\'')) {
        Some(b) => u8::from_str_radix(b, 2).ok(),
        None => v.parse::<u8>().ok(),
    };
    parsed.ok_or_else(|| at.err(format!("{field}: {v:?} is not a Status/Turn value")))
}

/// The E6POS (or POS) and E6AXIS (or AXIS) declarations of a `.dat`; other lines are
/// skipped.
pub fn read(text: &str, source_name: &str) -> Result<Vec<ReadTarget>, ControllerError> {
    read_lines(text, source_name, ';', |at, line, c| {
        let Some((kind, rest)) = declaration(line) else {
            return Ok(());
        };
        let pos = matches!(kind.as_str(), "E6POS" | "POS");
        if !pos && !matches!(kind.as_str(), "E6AXIS" | "AXIS") {
            return Ok(());
        }
        let (var, value) = rest
            .split_once('=')
            .ok_or_else(|| at.err(format!("DECL {kind} without `=`")))?;
        let var = var.trim();
        let body = value
            .trim()
            .strip_prefix('{')
            .and_then(|b| b.strip_suffix('}'))
            .ok_or_else(|| at.err(format!("{var}: the value is not a `{{…}}` structure")))?;
        let f = fields(at, body)?;
        let get = |key: &str| -> Result<f64, ControllerError> {
            let v = f
                .iter()
                .find(|(k, _)| k == key)
                .ok_or_else(|| at.err(format!("{var}: field {key} is missing")))?;
            at.number(&format!("{var}.{key}"), &v.1)
        };
        let allowed: &[&str] = if pos {
            &["X", "Y", "Z", "A", "B", "C", "S", "T"]
        } else {
            &["A1", "A2", "A3", "A4", "A5", "A6"]
        };
        for (k, _) in &f {
            let external = matches!(k.as_str(), "E1" | "E2" | "E3" | "E4" | "E5" | "E6");
            if !allowed.contains(&k.as_str()) && !external {
                return Err(at.err(format!("{var}: unknown field {k} in a {kind}")));
            }
        }
        if pos {
            let position = [get("X")?, get("Y")?, get("Z")?];
            let abc = [get("A")?, get("B")?, get("C")?];
            let st = match (
                f.iter().find(|(k, _)| k == "S"),
                f.iter().find(|(k, _)| k == "T"),
            ) {
                (Some(s), Some(t)) => Some((
                    bits(at, &format!("{var}.S"), &s.1)?,
                    bits(at, &format!("{var}.T"), &t.1)?,
                )),
                _ => None,
            };
            let t = c.target_for(var, |t| t.position_mm.is_some());
            t.position_mm = Some(position);
            t.orientation_wxyz = Some(EulerConvention::KUKA_ABC.to_quaternion(abc));
            t.kuka_status_turn = st;
        } else {
            let mut axes = [0.0; crate::AXES];
            for (i, a) in axes.iter_mut().enumerate() {
                *a = get(&format!("A{}", i + 1))?;
            }
            c.target_for(var, |t| t.axes_deg.is_some()).axes_deg = Some(axes);
        }
        Ok(())
    })
}
