//! The one writer of the report: typed rows become a [`Table`], and a table
//! becomes Markdown (for `report.md`) and JSON (for `report.json`). The
//! sections only decide which columns a row has.

use serde_json::{Map, Value};

use crate::measure::Measured;

/// One value of a row.
#[derive(Clone, Debug)]
pub enum Cell {
    Text(String),
    Count(u64),
    /// A number printed with this many decimals.
    Number(f64, usize),
    /// A ratio, printed as `1.23x`.
    Ratio(f64),
    /// The median of repeated measurements and their range, printed with
    /// this many decimals; marked when the repeats are noisy.
    Measured(Measured, usize),
    /// A cell with a warning about how far to trust it.
    Flagged(Box<Cell>, Flag),
    Empty,
}

/// Why a figure deserves care.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flag {
    /// A figure derived from repeats that spread by more than
    /// `measure::NOISY_SPREAD` (a ratio of two measurements, say).
    Noisy,
    /// A figure on all threads that is below the same figure on one
    /// thread: the extra threads cost time, or something else ran.
    BelowOneThread,
}

impl Flag {
    /// The mark after the figure in Markdown.
    pub const fn mark(self) -> &'static str {
        match self {
            Flag::Noisy => "⚠",
            Flag::BelowOneThread => "↓",
        }
    }

    /// The JSON key suffix set to `true`.
    const fn key(self) -> &'static str {
        match self {
            Flag::Noisy => "noisy",
            Flag::BelowOneThread => "below_one_thread",
        }
    }
}

impl Cell {
    /// This cell, flagged when `flag` is some.
    pub fn flagged(self, flag: Option<Flag>) -> Cell {
        match flag {
            Some(f) => Cell::Flagged(Box::new(self), f),
            None => self,
        }
    }

    /// The ratio `value` of measurements `of`, flagged noisy when any of
    /// them is.
    pub fn ratio_of(value: f64, of: &[Measured]) -> Cell {
        Cell::Ratio(value).flagged(of.iter().any(Measured::is_noisy).then_some(Flag::Noisy))
    }

    /// Whether this cell carries `flag` (a measured cell is noisy by its
    /// own repeats).
    pub fn has(&self, flag: Flag) -> bool {
        match self {
            Cell::Measured(m, _) => flag == Flag::Noisy && m.is_noisy(),
            Cell::Flagged(inner, f) => *f == flag || inner.has(flag),
            _ => false,
        }
    }
}

/// A column: its JSON key and its Markdown header.
#[derive(Clone, Debug)]
pub struct Column {
    pub key: String,
    pub header: String,
}

/// Rows under named columns.
#[derive(Clone, Debug)]
pub struct Table {
    pub columns: Vec<Column>,
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    /// A table with `(json key, header)` columns.
    pub fn new<K: Into<String>, H: Into<String>>(
        columns: impl IntoIterator<Item = (K, H)>,
    ) -> Table {
        Table {
            columns: columns
                .into_iter()
                .map(|(key, header)| Column {
                    key: key.into(),
                    header: header.into(),
                })
                .collect(),
            rows: Vec::new(),
        }
    }

    pub fn row(&mut self, cells: Vec<Cell>) {
        debug_assert_eq!(cells.len(), self.columns.len(), "row width");
        self.rows.push(cells);
    }

    pub fn markdown(&self) -> String {
        let mut md = format!(
            "| {} |\n|{}\n",
            self.columns
                .iter()
                .map(|c| c.header.as_str())
                .collect::<Vec<_>>()
                .join(" | "),
            "---|".repeat(self.columns.len())
        );
        for row in &self.rows {
            md += &format!(
                "| {} |\n",
                row.iter()
                    .map(markdown_cell)
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
        }
        md
    }

    /// The rows as an array of objects keyed by the columns' keys.
    /// A measured value `k` also gives `k_min`, `k_max` and `k_noisy`.
    pub fn json(&self) -> Value {
        Value::Array(
            self.rows
                .iter()
                .map(|row| {
                    let mut object = Map::new();
                    for (column, cell) in self.columns.iter().zip(row) {
                        insert_json(&mut object, &column.key, cell);
                    }
                    Value::Object(object)
                })
                .collect(),
        )
    }

    /// How many cells carry `flag`.
    pub fn count(&self, flag: Flag) -> usize {
        self.rows.iter().flatten().filter(|c| c.has(flag)).count()
    }
}

fn markdown_cell(cell: &Cell) -> String {
    match cell {
        Cell::Text(s) => s.clone(),
        Cell::Count(n) => n.to_string(),
        Cell::Number(v, d) => format!("{v:.d$}"),
        Cell::Ratio(v) => format!("{v:.2}x"),
        Cell::Measured(m, d) => format!(
            "{:.d$} ({:.d$}–{:.d$}){}",
            m.median,
            m.min,
            m.max,
            if m.is_noisy() {
                format!(" {}", Flag::Noisy.mark())
            } else {
                String::new()
            }
        ),
        Cell::Flagged(inner, flag) => {
            let text = markdown_cell(inner);
            if text.ends_with(flag.mark()) {
                text
            } else {
                format!("{text} {}", flag.mark())
            }
        }
        Cell::Empty => "–".into(),
    }
}

fn insert_json(object: &mut Map<String, Value>, key: &str, cell: &Cell) {
    let number = |v: f64| serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number);
    match cell {
        Cell::Text(s) => {
            object.insert(key.into(), Value::String(s.clone()));
        }
        Cell::Count(n) => {
            object.insert(key.into(), Value::from(*n));
        }
        Cell::Number(v, _) | Cell::Ratio(v) => {
            object.insert(key.into(), number(*v));
        }
        Cell::Measured(m, _) => {
            object.insert(key.into(), number(m.median));
            object.insert(format!("{key}_min"), number(m.min));
            object.insert(format!("{key}_max"), number(m.max));
            object.insert(format!("{key}_noisy"), Value::Bool(m.is_noisy()));
        }
        Cell::Flagged(inner, flag) => {
            insert_json(object, key, inner);
            object.insert(format!("{key}_{}", flag.key()), Value::Bool(true));
        }
        Cell::Empty => {
            object.insert(key.into(), Value::Null);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_table_gives_markdown_and_json_with_noise_marked() {
        let mut t = Table::new([("scene", "scene"), ("mrays", "Mrays/s")]);
        let steady = Measured {
            median: 10.0,
            min: 9.9,
            max: 10.1,
        };
        let noisy = Measured {
            median: 10.0,
            min: 8.0,
            max: 10.5,
        };
        t.row(vec![Cell::Text("a".into()), Cell::Measured(steady, 1)]);
        t.row(vec![Cell::Text("b".into()), Cell::Measured(noisy, 1)]);
        let md = t.markdown();
        assert!(md.contains("| a | 10.0 (9.9–10.1) |"), "{md}");
        assert!(md.contains("| b | 10.0 (8.0–10.5) ⚠ |"), "{md}");
        let json = t.json();
        assert_eq!(json[1]["mrays"], 10.0);
        assert_eq!(json[1]["mrays_noisy"], true);
        assert_eq!(json[0]["mrays_noisy"], false);
        assert_eq!(t.count(Flag::Noisy), 1);
    }

    #[test]
    fn flagged_cells_are_marked_once_and_keyed_in_json() {
        let mut t = Table::new([("kind", "kind"), ("ratio", "ratio")]);
        t.row(vec![
            Cell::Text("a".into()),
            Cell::Ratio(0.6).flagged(Some(Flag::BelowOneThread)),
        ]);
        t.row(vec![
            Cell::Text("b".into()),
            Cell::Ratio(1.2).flagged(Some(Flag::Noisy)).flagged(None),
        ]);
        let md = t.markdown();
        assert!(md.contains("| a | 0.60x ↓ |"), "{md}");
        assert!(md.contains("| b | 1.20x ⚠ |"), "{md}");
        let json = t.json();
        assert_eq!(json[0]["ratio"], 0.6);
        assert_eq!(json[0]["ratio_below_one_thread"], true);
        assert_eq!(json[1]["ratio_noisy"], true);
        assert_eq!(t.count(Flag::Noisy), 1);
        assert_eq!(t.count(Flag::BelowOneThread), 1);
    }
}
