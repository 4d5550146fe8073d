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
//! its files. `result.mesh` is a small binary form of [`TriMesh`] (positions
//! as f64, normals, labels) because glTF would round positions to f32 and
//! STL/OFF would drop labels and normals.

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::jobs::JobRecord;
use crate::io::Format;
use crate::trimesh::{Label, TriMesh};

/// Magic and version of `result.mesh`.
const MESH_MAGIC: &[u8; 8] = b"IRMESH01";

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
    {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    fs::rename(&tmp, path)?;
    sync_dir(dir)
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
        write_atomic(&dir.join("result.mesh"), &encode_mesh(mesh)?)
    }

    /// Reads the stored result file of `format`.
    pub fn read_result(&self, id: &str, format: Format) -> io::Result<Vec<u8>> {
        fs::read(self.dir(id)?.join(format!("result.{}", format.extension())))
    }

    /// Reads the exact result mesh.
    pub fn read_result_mesh(&self, id: &str) -> io::Result<TriMesh> {
        decode_mesh(&fs::read(self.dir(id)?.join("result.mesh"))?)
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

    /// Reads every job record. Directories without a record (interrupted
    /// submissions) are removed; unreadable records are reported and skipped.
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
                        tracing::error!(job_id = %name, "job record names another id; skipped")
                    }
                    Err(e) => {
                        tracing::error!(job_id = %name, error = %e, "corrupt job record; skipped")
                    }
                },
            }
        }
        Ok(out)
    }
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Serialises a mesh exactly: magic, five u64 counts (positions, triangles,
/// normals, face labels, label-JSON bytes), then the arrays little-endian.
pub fn encode_mesh(m: &TriMesh) -> io::Result<Vec<u8>> {
    let labels = serde_json::to_vec(&m.labels).map_err(io::Error::other)?;
    let mut out =
        Vec::with_capacity(48 + m.positions.len() * 48 + m.triangles.len() * 16 + labels.len());
    out.extend_from_slice(MESH_MAGIC);
    for n in [
        m.positions.len(),
        m.triangles.len(),
        m.normals.len(),
        m.face_labels.len(),
        labels.len(),
    ] {
        put_u64(&mut out, n as u64);
    }
    for p in m.positions.iter().chain(&m.normals) {
        for c in p.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &m.triangles {
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    for l in &m.face_labels {
        out.extend_from_slice(&l.to_le_bytes());
    }
    out.extend_from_slice(&labels);
    Ok(out)
}

struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn take(&mut self, n: usize) -> io::Result<&[u8]> {
        if n > self.0.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "result.mesh is truncated",
            ));
        }
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        Ok(a)
    }
    fn u64(&mut self) -> io::Result<u64> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().map_err(io::Error::other)?))
    }
    fn count(&mut self, elem: usize) -> io::Result<usize> {
        let n = usize::try_from(self.u64()?).map_err(io::Error::other)?;
        if n.checked_mul(elem).is_none_or(|b| b > self.0.len()) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "result.mesh count out of range",
            ));
        }
        Ok(n)
    }
    fn f64(&mut self) -> io::Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn u32(&mut self) -> io::Result<u32> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes(b.try_into().map_err(io::Error::other)?))
    }
    fn vec3(&mut self) -> io::Result<DVec3> {
        Ok(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
}

/// Reads [`encode_mesh`]'s format back, checking every count and the mesh's
/// invariants.
pub fn decode_mesh(bytes: &[u8]) -> io::Result<TriMesh> {
    let mut r = Reader(bytes);
    if r.take(8)? != MESH_MAGIC {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            "not a result.mesh file",
        ));
    }
    let np = r.count(24)?;
    let nt = r.count(12)?;
    let nn = r.count(24)?;
    let nl = r.count(4)?;
    let nj = r.count(1)?;
    let positions = (0..np).map(|_| r.vec3()).collect::<io::Result<_>>()?;
    let normals = (0..nn).map(|_| r.vec3()).collect::<io::Result<_>>()?;
    let triangles = (0..nt)
        .map(|_| Ok([r.u32()?, r.u32()?, r.u32()?]))
        .collect::<io::Result<_>>()?;
    let face_labels = (0..nl).map(|_| r.u32()).collect::<io::Result<_>>()?;
    let labels = serde_json::from_slice::<Vec<Label>>(r.take(nj)?).map_err(io::Error::other)?;
    let m = TriMesh {
        positions,
        triangles,
        normals,
        face_labels,
        labels,
    };
    m.check()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trimesh::Material;

    #[test]
    fn result_mesh_round_trips_exactly() {
        let mut m = crate::shapes::icosphere(1);
        m.positions[0].x += 1e-13;
        m.normals = m.positions.iter().map(|p| p.normalize()).collect();
        m.face_labels = (0..m.triangles.len() as u32).map(|f| f % 2).collect();
        m.labels = vec![
            Label::default(),
            Label {
                name: Some("red".into()),
                material: Some(Material {
                    base_color_factor: [1.0, 0.0, 0.0, 1.0],
                    ..Default::default()
                }),
            },
        ];
        let bytes = encode_mesh(&m).unwrap();
        assert_eq!(decode_mesh(&bytes).unwrap(), m);
        for cut in [0, 7, 20, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode_mesh(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

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
