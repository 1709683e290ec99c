//! Library error type. Every input error names the file and, where there is one, the
//! line (or row) and column, plus what was expected.

use std::path::PathBuf;

#[derive(thiserror::Error, Debug)]
pub enum Error {
    /// A value that could not be parsed or violates the schema.
    #[error("{file}: {loc}, column '{column}': {msg}")]
    Value {
        file: String,
        /// "line N" for text files, "row N" for Parquet.
        loc: String,
        column: String,
        msg: String,
    },
    /// Required columns absent.
    #[error(
        "{file}: missing required column(s) {missing:?}; found columns {found:?}; expected at least {expected:?}"
    )]
    MissingColumns {
        file: String,
        missing: Vec<String>,
        found: Vec<String>,
        expected: Vec<String>,
    },
    /// Two rows with the same (frame, particle).
    #[error("{file}: duplicate (frame {frame}, particle {particle}) at {first} and {second}")]
    Duplicate {
        file: String,
        frame: i64,
        particle: i64,
        first: String,
        second: String,
    },
    /// Anything else wrong with an input file as a whole.
    #[error("{file}: {msg}")]
    Input { file: String, msg: String },
    /// A parameter (flag, pipeline key) outside its domain.
    #[error("invalid parameter '{name}': {msg}")]
    Param { name: String, msg: String },
    // The cause is part of the message and deliberately not also a `source()`: the CLI
    // prints the chain (`{:#}`), which would state it twice (issue 24), and the library
    // formats these errors into others with `{e}`, which needs it in the message.
    #[error("{path}: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{context}: {cause}")]
    Polars {
        context: String,
        cause: polars::error::PolarsError,
    },
    /// Asked for something this build does not implement.
    #[error("not implemented: {0}")]
    NotImplemented(String),
    #[error("{0}")]
    Other(String),
    /// Stopped by SIGINT or SIGTERM after saving what can be resumed; `what` says where
    /// the work stands (the CLI adds the command that continues it).
    #[error("stopped by {}: {what}", crate::interrupt::name(*signal))]
    Interrupted { signal: i32, what: String },
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause,
        }
    }
    pub fn input(file: impl std::fmt::Display, msg: impl Into<String>) -> Self {
        Error::Input {
            file: file.to_string(),
            msg: msg.into(),
        }
    }
    pub fn param(name: impl Into<String>, msg: impl Into<String>) -> Self {
        Error::Param {
            name: name.into(),
            msg: msg.into(),
        }
    }
    /// The error of a run stopped by the pending signal, if one is pending.
    pub fn interrupted(what: impl Into<String>) -> Option<Self> {
        crate::interrupt::requested().map(|signal| Error::Interrupted {
            signal,
            what: what.into(),
        })
    }
    pub fn polars(context: impl Into<String>, cause: polars::error::PolarsError) -> Self {
        Error::Polars {
            context: context.into(),
            cause,
        }
    }
}
