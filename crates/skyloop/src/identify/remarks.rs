//! What identification tells the user beside the numbers: notes (what it chose on the user's
//! behalf) and warnings (what the user should act on), and the refusals `--allow-poor-fit` turns
//! into warnings.

use crate::error::{Error, Result};

/// The notes and warnings gathered along the identification.
#[derive(Debug, Default, Clone)]
pub(crate) struct Remarks {
    /// What the workflow chose on the user's behalf.
    pub notes: Vec<String>,
    /// What the user should act on.
    pub warnings: Vec<String>,
}

impl Remarks {
    /// A choice made for the user.
    pub fn note(&mut self, msg: String) {
        self.notes.push(msg);
    }

    /// Something the user should act on.
    pub fn warn(&mut self, msg: String) {
        self.warnings.push(msg);
    }

    /// Refuses with `msg` unless `allow` (the user's `--allow-poor-fit`), in which case `msg`
    /// becomes a warning and the work goes on.
    ///
    /// # Errors
    /// [`Error::Input`] with `msg` when `allow` is false.
    pub fn refuse_unless(&mut self, allow: bool, msg: String) -> Result<()> {
        if !allow {
            return Err(Error::Input(msg));
        }
        self.warnings.push(msg);
        Ok(())
    }
}
