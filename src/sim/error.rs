//! Errors of the simulator's files: the machine model, the plan, the concealed cases.

use crate::base::{ConfigError, FileError};
use crate::table::TableError;

/// What can be wrong with a machine model, a plan or a simulation's output files: the
/// shared file and configuration shapes ([`crate::base::error`]), or a table.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Table(#[from] TableError),
}
