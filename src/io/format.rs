//! Which table format a path names (by extension), and how its rows are located in
//! error messages: the one thing the table reader and the writers both need.

use crate::tracks::RowLocator;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    Csv,
    Parquet,
}

impl TableFormat {
    /// By extension: `.parquet`/`.pq` is Parquet, anything else CSV.
    pub fn of(path: &Path) -> TableFormat {
        match path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .as_deref()
        {
            Some("parquet") | Some("pq") => TableFormat::Parquet,
            _ => TableFormat::Csv,
        }
    }
    pub fn locator(self) -> RowLocator {
        match self {
            TableFormat::Csv => RowLocator::Line { first_data_line: 2 },
            TableFormat::Parquet => RowLocator::Row,
        }
    }
}
