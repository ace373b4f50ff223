//! The hard-case table: one row per case, one column per configuration.

use super::CaseReport;
use crate::accel::config::hard_case_modes;

/// The hard-case table as Markdown.
pub fn format_table(reports: &[CaseReport]) -> String {
    let mut out = String::from("| case | counted | ");
    let modes = hard_case_modes();
    out += &modes
        .iter()
        .map(|m| m.label())
        .collect::<Vec<_>>()
        .join(" | ");
    out += " |\n|---|---|";
    out += &"---|".repeat(modes.len());
    out += "\n";
    for r in reports {
        out += &format!(
            "| {}{} | {} |",
            r.name,
            if r.watertight_promise { " ★" } else { "" },
            r.failure
        );
        for (_, o) in &r.outcomes {
            let mut cell = format!(
                " {}/{} ({:.2}%)",
                o.failures,
                o.rays,
                100.0 * o.failures as f64 / o.rays.max(1) as f64
            );
            if let Some(d) = o.double_hits {
                cell += &format!(", {d} double");
            }
            if o.worst_t_error > 0.0 {
                cell += &format!(", max t err {:.1e}", o.worst_t_error);
            }
            if o.nans > 0 {
                cell += &format!(", {} NaN", o.nans);
            }
            if o.panics > 0 {
                cell += &format!(", {} PANICS", o.panics);
            }
            out += &cell;
            out += " |";
        }
        out += "\n";
    }
    out += "\n★ watertight mode promises zero here.\n";
    out
}
