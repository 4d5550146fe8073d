//! The data directory: uploads, job records and results on disk, written
//! atomically (temporary file, fsync, rename, fsync of the directory), so a
//! crash at any point leaves either the old or the new version of a file.
//!
//! Layout, one directory per job:
//!
//! ```text
//! <data-dir>/jobs/<id>/input          the uploaded mesh, as received
//! <data-dir>/jobs/<id>/buffer-<n>     external glTF buffers (uris in job.json)
//! <data-dir>/jobs/<id>/result.<ext>   the result in the job's output format
//! <data-dir>/jobs/<id>/result.mesh    the exact result for re-encoding
//! <data-dir>/jobs/<id>/job.json       the record; written last on creation
//! ```
//!
//! A job exists once its `job.json` does; a directory without one is an
//! interrupted submission and is removed at startup. Results are written
//! before the record that says `succeeded`, so a finished record always has
//! its files. A job directory whose record cannot be parsed is moved to
//! `<data-dir>/quarantine/`. `result.mesh` is the exact binary form of [`TriMesh`] written by
//! `crate::io::result_mesh`.

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use super::jobs::{Job, JobRecord};
use crate::io::{result_mesh, Format};
use crate::trimesh::TriMesh;

/// External glTF buffers keyed by `uri`.
pub type Buffers = HashMap<String, Vec<u8>>;

/// The data directory.
#[derive(Clone, Debug)]
pub struct Store {
    jobs: PathBuf,
}

/// Whether `id` has the shape of a job id (a UUID), so it is safe as a path.
pub fn is_job_id(id: &str) -> bool {
    id.len() == 36 && id.bytes().all(|b| b.is_ascii_hexdigit() || b == b'-')
}

fn sync_dir(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

/// Writes `bytes` to `path` atomically and durably.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path
        .parent()
        .ok_or_else(|| io::Error::other("path has no parent"))?;
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| io::Error::other("path has no file name"))?;
    let tmp = dir.join(format!(".{name}.tmp"));
    let written = (|| {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if written.is_err() {
        // A full disk must not also keep the half-written copy.
        let _ = fs::remove_file(&tmp);
    }
    written?;
    sync_dir(dir)
}

/// Whether an I/O error means the storage is out of space (or quota).
pub fn is_out_of_space(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded | io::ErrorKind::FileTooLarge
    )
}

/// Why the data directory cannot take new jobs now.
#[derive(Debug, thiserror::Error)]
pub enum StorageFault {
    /// Less free space than the configured reserve.
    #[error("the data directory has {free} bytes free, under the reserve of {reserve} bytes")]
    Full {
        /// Bytes available to the service.
        free: u64,
        /// `--min-free-bytes`.
        reserve: u64,
    },
    /// A write ran out of space (or quota).
    #[error("the data directory ran out of space: {0}")]
    OutOfSpace(io::Error),
    /// A file cannot be written there.
    #[error("the data directory is not writable: {0}")]
    NotWritable(io::Error),
}

impl StorageFault {
    /// Classifies a failed write.
    pub fn from_io(e: io::Error) -> Self {
        if is_out_of_space(&e) {
            StorageFault::OutOfSpace(e)
        } else {
            StorageFault::NotWritable(e)
        }
    }
}

/// Bytes available to unprivileged writers on the file system of `dir`;
/// `None` where it cannot be asked.
fn free_bytes(dir: &Path) -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::ffi::OsStrExt;
        let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
        // SAFETY: statvfs reads the NUL-terminated path and writes only into
        // the zeroed struct we own; it is valid for the duration of the call.
        let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
        let rc = unsafe { libc::statvfs(c.as_ptr(), &mut st) };
        // The fields are narrower than u64 on some targets.
        #[allow(clippy::useless_conversion)]
        let free = u64::from(st.f_bavail).saturating_mul(u64::from(st.f_frsize));
        (rc == 0).then_some(free)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = dir;
        None
    }
}

impl Store {
    /// Opens (creating if needed) the data directory.
    pub fn open(root: &Path) -> io::Result<Store> {
        let jobs = root.join("jobs");
        fs::create_dir_all(&jobs)?;
        Ok(Store { jobs })
    }

    fn dir(&self, id: &str) -> io::Result<PathBuf> {
        if !is_job_id(id) {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, "bad job id"));
        }
        Ok(self.jobs.join(id))
    }

    /// Checks that a file can be written in the data directory and that at
    /// least `reserve + extra` bytes are free there.
    pub fn check_writable(&self, reserve: u64, extra: u64) -> Result<(), StorageFault> {
        let probe = self.jobs.join(".probe");
        let wrote = File::create(&probe)
            .and_then(|mut f| f.write_all(b"ok").and_then(|_| f.sync_all()))
            .and_then(|_| fs::remove_file(&probe));
        if let Err(e) = wrote {
            let _ = fs::remove_file(&probe);
            return Err(StorageFault::from_io(e));
        }
        match free_bytes(&self.jobs) {
            Some(free) if free < reserve.saturating_add(extra) => {
                Err(StorageFault::Full { free, reserve })
            }
            _ => Ok(()),
        }
    }

    /// Stores a new job: its uploads first, the record last.
    pub fn create_job(
        &self,
        record: &JobRecord,
        mesh: &[u8],
        buffers: &[(String, Vec<u8>)],
    ) -> io::Result<()> {
        let dir = self.dir(&record.id)?;
        fs::create_dir(&dir)?;
        let result = (|| {
            write_atomic(&dir.join("input"), mesh)?;
            for (i, (_, bytes)) in buffers.iter().enumerate() {
                write_atomic(&dir.join(format!("buffer-{i}")), bytes)?;
            }
            self.write_record(record)?;
            sync_dir(&self.jobs)
        })();
        if result.is_err() {
            let _ = fs::remove_dir_all(&dir);
        }
        result
    }

    /// Replaces a job's record. Fails if the job's directory is gone.
    pub fn write_record(&self, record: &JobRecord) -> io::Result<()> {
        let bytes = serde_json::to_vec(record).map_err(io::Error::other)?;
        write_atomic(&self.dir(&record.id)?.join("job.json"), &bytes)
    }

    /// Writes a job's record unless it was deleted; failures are logged,
    /// because the caller (a worker or a handler that already answered)
    /// has nobody to report them to.
    pub fn persist(&self, job: &Job) {
        if job.is_deleted() {
            return;
        }
        let _g = job.persist_lock.lock().unwrap_or_else(|p| p.into_inner());
        if job.is_deleted() {
            return;
        }
        let snap = job.snapshot();
        if let Err(e) = self.write_record(&snap) {
            tracing::error!(job_id = %snap.id, error = %e, "cannot write job record");
        }
    }

    /// The uploaded mesh and its external buffers keyed by `uri`.
    pub fn read_input(&self, record: &JobRecord) -> io::Result<(Vec<u8>, Buffers)> {
        let dir = self.dir(&record.id)?;
        let mesh = fs::read(dir.join("input"))?;
        let mut buffers = HashMap::new();
        for (i, uri) in record.input.buffers.iter().enumerate() {
            buffers.insert(uri.clone(), fs::read(dir.join(format!("buffer-{i}")))?);
        }
        Ok((mesh, buffers))
    }

    /// Stores a result: the encoded file and the exact mesh.
    pub fn write_result(
        &self,
        id: &str,
        format: Format,
        encoded: &[u8],
        mesh: &TriMesh,
    ) -> io::Result<()> {
        let dir = self.dir(id)?;
        write_atomic(&dir.join(format!("result.{}", format.extension())), encoded)?;
        write_atomic(&dir.join("result.mesh"), &result_mesh::encode(mesh)?)
    }

    /// Reads the stored result file of `format`.
    pub fn read_result(&self, id: &str, format: Format) -> io::Result<Vec<u8>> {
        fs::read(self.dir(id)?.join(format!("result.{}", format.extension())))
    }

    /// Reads the exact result mesh.
    pub fn read_result_mesh(&self, id: &str) -> io::Result<TriMesh> {
        result_mesh::decode(&fs::read(self.dir(id)?.join("result.mesh"))?)
    }

    /// Removes a job's uploads and results but keeps its record.
    pub fn remove_files(&self, id: &str) -> io::Result<()> {
        let dir = self.dir(id)?;
        for entry in fs::read_dir(&dir)? {
            let entry = entry?;
            if entry.file_name() != "job.json" {
                fs::remove_file(entry.path())?;
            }
        }
        sync_dir(&dir)
    }

    /// Removes a job entirely.
    pub fn remove_job(&self, id: &str) -> io::Result<()> {
        match fs::remove_dir_all(self.dir(id)?) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }

    /// Moves a job directory whose record cannot be used to
    /// `<data-dir>/quarantine/<id>` (with a suffix if that exists), so that
    /// it is neither loaded again at every start nor lost; `None` if it
    /// could not be moved.
    fn quarantine(&self, dir: &Path, name: &str) -> Option<PathBuf> {
        let root = self.jobs.parent()?.join("quarantine");
        fs::create_dir_all(&root).ok()?;
        let mut to = root.join(name);
        let mut n = 1;
        while to.exists() {
            to = root.join(format!("{name}.{n}"));
            n += 1;
        }
        fs::rename(dir, &to).ok()?;
        Some(to)
    }

    /// Reads every job record. Directories without a record (interrupted
    /// submissions) are removed; records that cannot be parsed are reported
    /// and moved to the quarantine folder.
    pub fn load_all(&self) -> io::Result<Vec<JobRecord>> {
        let mut out = Vec::new();
        for entry in fs::read_dir(&self.jobs)? {
            let entry = entry?;
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if !path.is_dir() || !is_job_id(&name) {
                continue;
            }
            match fs::read(path.join("job.json")) {
                Err(e) if e.kind() == io::ErrorKind::NotFound => {
                    tracing::warn!(job_id = %name, "removing an interrupted submission");
                    fs::remove_dir_all(&path)?;
                }
                Err(e) => tracing::error!(job_id = %name, error = %e, "cannot read job record"),
                Ok(bytes) => match serde_json::from_slice::<JobRecord>(&bytes) {
                    Ok(r) if r.id == name => out.push(r),
                    Ok(_) => {
                        let to = self.quarantine(&path, &name);
                        tracing::error!(job_id = %name, moved_to = ?to.as_deref().map(Path::display).map(|d| d.to_string()), "job record names another id; moved to quarantine")
                    }
                    Err(e) => {
                        let to = self.quarantine(&path, &name);
                        tracing::error!(job_id = %name, error = %e, moved_to = ?to.as_deref().map(Path::display).map(|d| d.to_string()), "corrupt job record; moved to quarantine")
                    }
                },
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("job.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"two");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn job_ids_are_checked_before_touching_paths() {
        assert!(is_job_id("0f8fad5b-d9cb-469f-a165-70867728950e"));
        assert!(!is_job_id("../../../../etc/passwd-aaaaaaaaaaaaaaaaa"));
        assert!(!is_job_id("x"));
    }
}
