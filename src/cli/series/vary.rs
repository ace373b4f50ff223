//! What a series varies: `--vary NAME=VALUES` parsed into axes (lists and
//! ranges), and how values, flags and the fixed options are shown.

use std::path::Path;

use super::variable_options;

/// The most values one series renders (ranges and lists alike).
pub(super) const MAX_VALUES: usize = 64;

/// `NAME=VALUES` as the name and the list of values.
pub(super) fn parse_vary(text: &str) -> Result<(String, Vec<String>), String> {
    let bad = |why: &str| format!("--vary {text}: {why}");
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| bad("expected OPTION=VALUES, e.g. l=1,4,16,64"))?;
    let name = name.trim().trim_start_matches('-').to_string();
    let variable = variable_options();
    if !variable.contains(&name) {
        return Err(bad(&format!(
            "'{name}' is not an option a series varies (one of {})",
            variable.join(", ")
        )));
    }
    let values = values.trim();
    let list: Vec<String> = if let Some((a, b)) =
        values.split_once("..").filter(|_| !values.contains(','))
    {
        let (a, b): (i64, i64) = match (a.trim().parse::<i64>(), b.trim().parse::<i64>()) {
            (Ok(a), Ok(b)) if a <= b && b.checked_sub(a).is_some_and(|d| d < 64) => (a, b),
            _ => {
                return Err(bad(
                    "expected A..B with whole numbers A <= B, at most 64 values",
                ))
            }
        };
        (a..=b).map(|v| v.to_string()).collect()
    } else {
        let parts: Vec<&str> = values.split(',').map(str::trim).collect();
        match parts.iter().position(|p| *p == "...") {
            None => parts.iter().map(|p| p.to_string()).collect(),
            Some(at) => continued(&parts, at).ok_or_else(|| {
                bad("'...' needs two numbers before it and one after, e.g. 1,2,4,...,1024 (at most 64 values)")
            })?,
        }
    };
    if list.is_empty() || list.iter().any(|v| v.is_empty()) {
        return Err(bad("an empty value"));
    }
    // A sheet of more tiles is unreadable, and each value is a render.
    if list.len() > MAX_VALUES {
        return Err(bad(&format!(
            "{} values; a series takes at most {MAX_VALUES}",
            list.len()
        )));
    }
    Ok((name, list))
}

/// `a, b, ..., z` continued geometrically when b / a is a whole ratio
/// above 1, else arithmetically by b - a, up to z.
pub(super) fn continued(parts: &[&str], at: usize) -> Option<Vec<String>> {
    if at < 2 || at + 2 != parts.len() {
        return None;
    }
    let number = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
    let (a, b, end) = (
        number(parts[at - 2])?,
        number(parts[at - 1])?,
        number(parts[at + 1])?,
    );
    if b <= a {
        return None;
    }
    let mut out: Vec<String> = parts[..at].iter().map(|p| p.to_string()).collect();
    let geometric = a > 0.0 && (b / a).fract() == 0.0;
    let next = |v: f64| if geometric { v * (b / a) } else { v + (b - a) };
    let mut v = next(b);
    while v <= end + 1e-9 && out.len() < 64 {
        out.push(format_number(v));
        v = next(v);
    }
    (out.last().map(String::as_str) == Some(&format_number(end))).then_some(out)
}

fn format_number(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// The flag that sets option `name`.
pub(super) fn flag(name: &str) -> String {
    if name.len() == 1 {
        format!("-{name}")
    } else {
        format!("--{name}")
    }
}

/// The shared options as typed, without the series' own (`--vary`,
/// `--columns`, `-f`) and the scene: the sheet's title.
pub(super) fn fixed_options(raw: &[String], scene: Option<&Path>) -> String {
    let mut out = Vec::new();
    let mut i = 0;
    while i < raw.len() {
        let a = raw[i].as_str();
        if matches!(a, "--vary" | "--columns" | "-f") {
            i += 2;
            continue;
        }
        if a.starts_with("--vary=") || a.starts_with("--columns=") || scene == Some(Path::new(a)) {
            i += 1;
            continue;
        }
        out.push(a.to_string());
        i += 1;
    }
    out.join(" ")
}

/// One varied option and its values.
pub(super) struct Axis {
    pub(super) name: String,
    pub(super) values: Vec<String>,
}

/// Each axis's value of a tile as captions and file names show it.
pub(super) fn shown_values<'v>(axes: &[Axis], values: &'v [String]) -> Vec<&'v str> {
    axes.iter().zip(values).map(|(a, v)| a.shown(v)).collect()
}

impl Axis {
    /// A value as captions and file names show it: a scene by its file
    /// name without `.dae`.
    pub(super) fn shown<'v>(&self, value: &'v str) -> &'v str {
        match self.name.as_str() {
            "scene" => Path::new(value)
                .file_name()
                .and_then(|f| f.to_str())
                .unwrap_or(value)
                .trim_end_matches(".dae"),
            _ => value,
        }
    }

    /// The option as the title names it.
    pub(super) fn flag(&self) -> String {
        if self.name == "scene" {
            self.name.clone()
        } else {
            flag(&self.name)
        }
    }
}

/// The varied options: one or two, each named once, at most
/// [`MAX_VALUES`] renders in all.
pub(super) fn axes(vary: &[String]) -> Result<Vec<Axis>, String> {
    if vary.len() > 2 {
        return Err("--vary: at most two options (rows and columns)".into());
    }
    let mut axes = Vec::new();
    for text in vary {
        let (name, values) = parse_vary(text)?;
        if axes.iter().any(|a: &Axis| a.name == name) {
            return Err(format!("--vary {text}: '{name}' is varied twice"));
        }
        axes.push(Axis { name, values });
    }
    let renders: usize = axes.iter().map(|a| a.values.len()).product();
    if renders > MAX_VALUES {
        return Err(format!(
            "--vary: {renders} renders; a series takes at most {MAX_VALUES}"
        ));
    }
    Ok(axes)
}
