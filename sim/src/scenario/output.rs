//! Output files written whole or not at all: under a temporary name (`NAME.partial`), moved into
//! place once complete, and removed if the run fails first.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use super::ScenarioError;

/// An output file written under a temporary name and moved into place only when complete; one
/// dropped before that removes the temporary file.
pub(crate) struct PendingFile {
    target: PathBuf,
    temporary: PathBuf,
    file: Option<File>,
}

impl PendingFile {
    /// Opens `target`'s temporary file (fails at once if the place is not writable).
    pub(crate) fn create(target: &Path) -> Result<PendingFile, ScenarioError> {
        let mut name = target.as_os_str().to_owned();
        name.push(".partial");
        let temporary = PathBuf::from(name);
        let file = File::create(&temporary).map_err(|e| {
            ScenarioError::new(format!("cannot create {}: {e}", temporary.display()))
        })?;
        Ok(PendingFile {
            target: target.to_path_buf(),
            temporary,
            file: Some(file),
        })
    }

    /// Writes `contents` and moves the file into place.
    pub(crate) fn commit(mut self, contents: &[u8]) -> Result<PathBuf, ScenarioError> {
        let fail = |e: io::Error| {
            ScenarioError::new(format!("cannot write {}: {e}", self.target.display()))
        };
        let mut file = self.file.take().expect("a pending file is committed once");
        file.write_all(contents).map_err(fail)?;
        file.sync_data().map_err(fail)?;
        std::fs::rename(&self.temporary, &self.target).map_err(fail)?;
        Ok(self.target.clone())
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if self.file.is_some() {
            // A half-written output is useless; nobody can report a failure to remove it.
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Writes `contents` to `path` whole or not at all.
pub(crate) fn write_file(path: &Path, contents: &str) -> Result<PathBuf, ScenarioError> {
    PendingFile::create(path)?.commit(contents.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pending_file_appears_only_when_committed() {
        let dir = std::env::temp_dir().join(format!("cansim-pending-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.log");
        let partial = dir.join("out.log.partial");
        drop(PendingFile::create(&target).unwrap());
        assert!(!partial.exists() && !target.exists());
        let written = PendingFile::create(&target)
            .unwrap()
            .commit(b"x\n")
            .unwrap();
        assert_eq!(std::fs::read_to_string(&written).unwrap(), "x\n");
        assert!(!partial.exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}
