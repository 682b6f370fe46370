//! One typed reader of a run directory's outputs: `summary.json` as a
//! [`RunSummary`] and `series.csv` as a [`Series`]. A missing, renamed or
//! malformed field is an error that names the file and the field, never a
//! NaN.

use crate::io::summary::RunSummary;
use std::path::{Path, PathBuf};

/// Why a run directory's output could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {}{reason}", path.display(), field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default())]
pub struct RunDirError {
    /// The file.
    pub path: PathBuf,
    /// The field (a dotted path in `summary.json`, a column of
    /// `series.csv`), when one is to blame.
    pub field: Option<String>,
    /// What is wrong.
    pub reason: String,
}

impl RunSummary {
    /// Reads `DIR/summary.json`.
    pub fn read(dir: &Path) -> Result<RunSummary, RunDirError> {
        let path = dir.join("summary.json");
        let err = |field: Option<String>, reason: String| RunDirError {
            path: path.clone(),
            field,
            reason,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| err(None, e.to_string()))?;
        let mut de = serde_json::Deserializer::from_str(&text);
        serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let at = e.path().to_string();
            let inner = e.into_inner();
            // A missing field is reported at its parent: name it whole.
            let reason = inner.to_string();
            let missing = reason
                .strip_prefix("missing field `")
                .and_then(|r| r.split('`').next())
                .map(|f| {
                    if at == "." {
                        f.to_string()
                    } else {
                        format!("{at}.{f}")
                    }
                });
            match missing {
                Some(field) => err(Some(field), "missing".into()),
                None => err((at != ".").then_some(at), reason),
            }
        })
    }
}

/// `series.csv`: one row per recorded iteration, one named column per
/// quantity (see the run's README section on outputs for the columns).
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// The file read.
    pub path: PathBuf,
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Rows of values (`NaN` where the run wrote `NaN`, e.g. a quantity
    /// not yet defined).
    pub rows: Vec<Vec<f64>>,
}

impl Series {
    /// Reads `DIR/series.csv`: a header, then rows of numbers, each as long
    /// as the header.
    pub fn read(dir: &Path) -> Result<Series, RunDirError> {
        let path = dir.join("series.csv");
        let err = |field: Option<String>, reason: String| RunDirError {
            path: path.clone(),
            field,
            reason,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| err(None, e.to_string()))?;
        let mut lines = text.lines();
        let columns: Vec<String> = lines
            .next()
            .filter(|h| !h.is_empty())
            .ok_or_else(|| err(None, "no header".into()))?
            .split(',')
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for (i, line) in lines.enumerate() {
            let values: Vec<&str> = line.split(',').collect();
            if values.len() != columns.len() {
                return Err(err(
                    None,
                    format!(
                        "line {}: {} values for {} columns",
                        i + 2,
                        values.len(),
                        columns.len()
                    ),
                ));
            }
            let row = values
                .iter()
                .zip(&columns)
                .map(|(v, c)| {
                    v.parse::<f64>().map_err(|_| {
                        err(
                            Some(c.clone()),
                            format!("line {}: `{v}` is not a number", i + 2),
                        )
                    })
                })
                .collect::<Result<Vec<f64>, _>>()?;
            rows.push(row);
        }
        Ok(Series {
            path,
            columns,
            rows,
        })
    }

    /// Index of the column `name`; an error naming it if there is none.
    pub fn index(&self, name: &str) -> Result<usize, RunDirError> {
        self.columns
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| RunDirError {
                path: self.path.clone(),
                field: Some(name.to_string()),
                reason: "no such column".into(),
            })
    }

    /// The column `name`, row by row.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, RunDirError> {
        let i = self.index(name)?;
        Ok(self.rows.iter().map(|r| r[i]).collect())
    }

    /// The value of column `name` in the first row.
    pub fn first(&self, name: &str) -> Result<f64, RunDirError> {
        let i = self.index(name)?;
        self.rows.first().map(|r| r[i]).ok_or_else(|| RunDirError {
            path: self.path.clone(),
            field: None,
            reason: "no rows".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_errors_name_the_file_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let write = |text: &str| std::fs::write(dir.path().join("series.csv"), text).unwrap();
        write("iteration,energy_total\n0,1.5\n10,NaN\n");
        let s = Series::read(dir.path()).unwrap();
        assert_eq!(s.column("iteration").unwrap(), vec![0.0, 10.0]);
        assert!(s.column("energy_total").unwrap()[1].is_nan());
        assert_eq!(s.first("energy_total").unwrap(), 1.5);
        let e = s.column("energy").unwrap_err().to_string();
        assert!(
            e.contains("series.csv") && e.contains("field `energy`"),
            "{e}"
        );
        write("iteration,energy_total\n0,x\n");
        let e = Series::read(dir.path()).unwrap_err().to_string();
        assert!(e.contains("field `energy_total`: line 2"), "{e}");
        write("iteration,energy_total\n0\n");
        assert!(Series::read(dir.path()).is_err());
    }
}
