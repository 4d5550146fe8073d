//! API keys: the key file, who a request comes from (its [`Caller`]), and
//! the per-key limits: a token-bucket rate limit on every `/v1` request and
//! the quotas that submit checks (jobs queued and running at once, bytes
//! stored).
//!
//! The key file holds one JSON object per line: a unique `name`, the
//! SHA-256 of the key (`sha256`, hex) and optional limits. The keys
//! themselves are never stored: `isoremesh keys new` prints a key once and
//! appends its hash. A key is 32 random bytes, so a plain SHA-256 is as
//! hard to invert as the key is to guess, and no slow password hash is
//! needed. A presented key is hashed and compared with every entry in
//! constant time, so neither the time of a refusal nor of an acceptance
//! tells a client how close its guess was or which entry matched.
//!
//! Jobs belong to the key's name, so a key replaced under the same name
//! keeps its jobs. With no key file the service is open, as for local use,
//! and every job belongs to nobody.

use std::collections::HashMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Instant;

use axum::extract::{Request, State};
use axum::http::{header, HeaderValue};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

use super::metrics::{Metrics, Refusal};
use super::problem::{Problem, ProblemKind};
use super::server::AppState;

/// What every generated key starts with, so that a leaked key is easy to
/// recognise in a scanner or a log.
pub const KEY_PREFIX: &str = "irk_";
/// Default jobs a key may have queued and running at once.
pub const DEFAULT_MAX_ACTIVE_JOBS: u32 = 16;
/// Default sustained requests per second per key.
pub const DEFAULT_REQUESTS_PER_SECOND: f64 = 20.0;
/// Default burst: requests a key may send at once after idling.
pub const DEFAULT_BURST: u32 = 40;
/// Default bytes a key may keep stored (uploads and results): 8 GiB.
pub const DEFAULT_MAX_STORED_BYTES: u64 = 8 << 30;
/// Seconds a client refused for its active jobs should wait.
const ACTIVE_RETRY_SECS: u64 = 5;

/// One line of the key file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyLine {
    /// The key's unique name; its jobs belong to it.
    pub name: String,
    /// SHA-256 of the key, lower-case hex.
    pub sha256: String,
    /// Jobs queued and running at once.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_active_jobs: Option<u32>,
    /// Sustained requests per second.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub requests_per_second: Option<f64>,
    /// Requests at once after idling.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub burst: Option<u32>,
    /// Bytes of uploads and results kept at once.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_stored_bytes: Option<u64>,
}

/// A key's limits, with the defaults filled in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quotas {
    /// Jobs queued and running at once.
    pub max_active_jobs: u32,
    /// Sustained requests per second.
    pub requests_per_second: f64,
    /// Requests at once after idling.
    pub burst: u32,
    /// Bytes of uploads and results kept at once.
    pub max_stored_bytes: u64,
}

/// A configured key (its hash, never the key).
#[derive(Debug)]
pub struct ApiKey {
    /// The name its jobs belong to.
    pub name: String,
    digest: [u8; 32],
    /// Its limits.
    pub quotas: Quotas,
}

/// A key file that cannot be used; the message names the line.
#[derive(Debug, thiserror::Error)]
pub enum KeyFileError {
    /// The file cannot be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The key file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A line is not a valid entry.
    #[error("{path}:{line}: {message}")]
    Invalid {
        /// The key file.
        path: PathBuf,
        /// Its 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// The keys of one reading of the key file.
#[derive(Debug, Default)]
pub struct KeySet {
    keys: Vec<Arc<ApiKey>>,
}

fn digest(key: &str) -> [u8; 32] {
    Sha256::digest(key.as_bytes()).into()
}

impl KeySet {
    /// Reads the key file.
    pub fn load(path: &Path) -> Result<KeySet, KeyFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| KeyFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(path, &text)
    }

    /// Parses key-file text; blank lines and lines starting with `#` are
    /// skipped. Names must be unique, 1 to 64 characters of letters,
    /// digits, `-`, `_` and `.`; limits must be positive.
    pub fn parse(path: &Path, text: &str) -> Result<KeySet, KeyFileError> {
        let mut keys: Vec<Arc<ApiKey>> = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let bad = |message: String| KeyFileError::Invalid {
                path: path.to_path_buf(),
                line: i + 1,
                message,
            };
            let entry: KeyLine =
                serde_json::from_str(line).map_err(|e| bad(format!("not a key entry: {e}")))?;
            check_name(&entry.name).map_err(|m| bad(m.to_string()))?;
            if keys.iter().any(|k| k.name == entry.name) {
                return Err(bad(format!("the name {:?} is used twice", entry.name)));
            }
            let mut d = [0u8; 32];
            hex::decode_to_slice(&entry.sha256, &mut d)
                .map_err(|_| bad("sha256 must be 64 hex digits".into()))?;
            let quotas = Quotas {
                max_active_jobs: entry.max_active_jobs.unwrap_or(DEFAULT_MAX_ACTIVE_JOBS),
                requests_per_second: entry
                    .requests_per_second
                    .unwrap_or(DEFAULT_REQUESTS_PER_SECOND),
                burst: entry.burst.unwrap_or(DEFAULT_BURST),
                max_stored_bytes: entry.max_stored_bytes.unwrap_or(DEFAULT_MAX_STORED_BYTES),
            };
            if quotas.max_active_jobs == 0
                || quotas.burst == 0
                || quotas.max_stored_bytes == 0
                || !(quotas.requests_per_second.is_finite() && quotas.requests_per_second > 0.0)
            {
                return Err(bad("every limit must be positive".into()));
            }
            keys.push(Arc::new(ApiKey {
                name: entry.name,
                digest: d,
                quotas,
            }));
        }
        Ok(KeySet { keys })
    }

    /// Number of keys.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The key whose hash is `presented`'s. Every entry is compared, in
    /// constant time, whatever matches.
    pub fn authenticate(&self, presented: &str) -> Option<Arc<ApiKey>> {
        let d = digest(presented);
        let mut found = None;
        for k in &self.keys {
            if bool::from(k.digest.ct_eq(&d)) {
                found = Some(Arc::clone(k));
            }
        }
        found
    }
}

fn check_name(name: &str) -> Result<(), &'static str> {
    let ok = (1..=64).contains(&name.len())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if ok {
        Ok(())
    } else {
        Err("a name is 1 to 64 letters, digits, '-', '_' or '.'")
    }
}

/// A new random key: [`KEY_PREFIX`] and 32 random bytes in hex.
pub fn generate_key() -> Result<String, getrandom::Error> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes)?;
    Ok(format!("{KEY_PREFIX}{}", hex::encode(bytes)))
}

/// `isoremesh keys new`: makes a key named `entry.name` (its `sha256` is
/// replaced), appends its hash to `file` (created, readable by its owner
/// only, when missing) and returns the key, which is stored nowhere.
pub fn append_new_key(file: &Path, mut entry: KeyLine) -> Result<String, KeyFileError> {
    let io = |source| KeyFileError::Io {
        path: file.to_path_buf(),
        source,
    };
    let existing = match std::fs::read_to_string(file) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(io(e)),
    };
    let invalid = |message: String| KeyFileError::Invalid {
        path: file.to_path_buf(),
        line: existing.lines().count() + 1,
        message,
    };
    let set = KeySet::parse(file, &existing)?;
    check_name(&entry.name).map_err(|m| invalid(m.to_string()))?;
    if set.keys.iter().any(|k| k.name == entry.name) {
        return Err(invalid(format!("a key named {:?} exists", entry.name)));
    }
    let key = generate_key().map_err(|e| io(std::io::Error::other(e.to_string())))?;
    entry.sha256 = hex::encode(digest(&key));
    let line = serde_json::to_string(&entry).map_err(|e| invalid(e.to_string()))?;
    // Validate the new line as the service will read it.
    KeySet::parse(file, &line)?;
    let mut options = std::fs::OpenOptions::new();
    options.create(true).append(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut f = options.open(file).map_err(io)?;
    let sep = if existing.is_empty() || existing.ends_with('\n') {
        ""
    } else {
        "\n"
    };
    writeln!(f, "{sep}{line}")
        .and_then(|_| f.sync_all())
        .map_err(io)?;
    Ok(key)
}

/// Who sent a request: a key, or nobody when no keys are configured.
#[derive(Clone, Debug)]
pub struct Caller(pub Option<Arc<ApiKey>>);

impl Caller {
    /// The owner its jobs get.
    pub fn owner(&self) -> Option<&str> {
        self.0.as_deref().map(|k| k.name.as_str())
    }

    /// Whether a job of `owner` is visible to this caller: with keys, only
    /// the key's own; without, all.
    pub fn may_see(&self, owner: Option<&str>) -> bool {
        match &self.0 {
            Some(k) => owner == Some(k.name.as_str()),
            None => true,
        }
    }
}

/// A token bucket.
#[derive(Debug)]
struct Bucket {
    tokens: f64,
    at: Instant,
}

/// The configured keys (re-read on SIGHUP) and the rate limiter's buckets.
#[derive(Debug)]
pub struct Auth {
    path: Option<PathBuf>,
    keys: RwLock<Arc<KeySet>>,
    buckets: Mutex<HashMap<String, Bucket>>,
    /// Per key name, the (jobs, bytes) of submissions admitted but not yet
    /// registered.
    pending: Mutex<HashMap<String, (u64, u64)>>,
}

impl Auth {
    /// Reads the key file at `path`, if any. An existing but empty file is
    /// an error: it would leave the service open by accident.
    pub fn open(path: Option<&Path>) -> Result<Auth, KeyFileError> {
        let keys = match path {
            Some(p) => {
                let set = KeySet::load(p)?;
                if set.is_empty() {
                    return Err(KeyFileError::Invalid {
                        path: p.to_path_buf(),
                        line: 0,
                        message: "the key file holds no key; add one with `isoremesh keys new`"
                            .into(),
                    });
                }
                set
            }
            None => KeySet::default(),
        };
        Ok(Auth {
            path: path.map(Path::to_path_buf),
            keys: RwLock::new(Arc::new(keys)),
            buckets: Mutex::new(HashMap::new()),
            pending: Mutex::new(HashMap::new()),
        })
    }

    /// Whether requests need a key.
    pub fn enabled(&self) -> bool {
        self.path.is_some()
    }

    fn keys(&self) -> Arc<KeySet> {
        Arc::clone(&self.keys.read().unwrap_or_else(|p| p.into_inner()))
    }

    /// Reads the key file again; on an error the keys in use stay. Returns
    /// the number of keys now in use.
    pub fn reload(&self) -> Result<usize, KeyFileError> {
        let Some(path) = &self.path else {
            return Ok(0);
        };
        let set = KeySet::load(path)?;
        if set.is_empty() {
            return Err(KeyFileError::Invalid {
                path: path.clone(),
                line: 0,
                message: "the key file holds no key; the previous keys stay in use".into(),
            });
        }
        let n = set.len();
        *self.keys.write().unwrap_or_else(|p| p.into_inner()) = Arc::new(set);
        let mut buckets = self.buckets.lock().unwrap_or_else(|p| p.into_inner());
        let names = self.keys();
        buckets.retain(|name, _| names.keys.iter().any(|k| &k.name == name));
        Ok(n)
    }

    /// The caller of a request with these headers, or a 401 problem.
    pub fn caller(&self, headers: &axum::http::HeaderMap) -> Result<Caller, Problem> {
        if !self.enabled() {
            return Ok(Caller(None));
        }
        let unauthorized = |detail: &str| {
            Problem::new(ProblemKind::Unauthorized, detail).with_field("Authorization")
        };
        let value = headers
            .get(header::AUTHORIZATION)
            .ok_or_else(|| unauthorized("send an API key as `Authorization: Bearer <key>`"))?;
        let token = value
            .to_str()
            .ok()
            .and_then(|v| {
                let (scheme, rest) = v.split_once(' ')?;
                scheme.eq_ignore_ascii_case("bearer").then(|| rest.trim())
            })
            .filter(|t| !t.is_empty())
            .ok_or_else(|| unauthorized("the Authorization header must be `Bearer <key>`"))?;
        self.keys()
            .authenticate(token)
            .map(|k| Caller(Some(k)))
            .ok_or_else(|| unauthorized("the API key is not valid"))
    }

    /// Takes one request from the key's bucket, or says how many seconds
    /// until one is there.
    fn take(&self, key: &ApiKey, now: Instant) -> Result<(), u64> {
        let q = key.quotas;
        let mut buckets = self.buckets.lock().unwrap_or_else(|p| p.into_inner());
        let b = buckets.entry(key.name.clone()).or_insert(Bucket {
            tokens: f64::from(q.burst),
            at: now,
        });
        let refill = now.duration_since(b.at).as_secs_f64() * q.requests_per_second;
        b.tokens = (b.tokens + refill).min(f64::from(q.burst));
        b.at = now;
        if b.tokens >= 1.0 {
            b.tokens -= 1.0;
            Ok(())
        } else {
            Err(((1.0 - b.tokens) / q.requests_per_second).ceil().max(1.0) as u64)
        }
    }
}

/// Middleware of every `/v1` route: finds the [`Caller`] (401 without a
/// valid key when keys are configured), applies its rate limit (429 with
/// `Retry-After`) and hands the caller to the handler as an extension.
pub async fn require_key(State(svc): State<AppState>, mut req: Request, next: Next) -> Response {
    let caller = match svc.auth.caller(req.headers()) {
        Ok(c) => c,
        Err(p) => {
            svc.metrics.refused(Refusal::Unauthorized);
            let mut resp = p.into_response();
            resp.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                HeaderValue::from_static("Bearer realm=\"isoremesh\""),
            );
            return resp;
        }
    };
    if let Some(key) = &caller.0 {
        if let Err(wait) = svc.auth.take(key, Instant::now()) {
            svc.metrics.refused(Refusal::RateLimited);
            return Problem::new(
                ProblemKind::RateLimited,
                format!(
                    "the key {:?} may send {} requests per second (bursts of {})",
                    key.name, key.quotas.requests_per_second, key.quotas.burst
                ),
            )
            .with_retry_after(wait)
            .into_response();
        }
    }
    req.extensions_mut().insert(caller);
    next.run(req).await
}

/// A submission counted against its key's quotas from the check until its
/// job is registered, so that concurrent submissions cannot together pass
/// a quota that each alone would.
#[derive(Debug)]
pub struct Admission<'a> {
    auth: &'a Auth,
    name: Option<String>,
    bytes: u64,
}

impl Drop for Admission<'_> {
    fn drop(&mut self) {
        let Some(name) = &self.name else { return };
        let mut pending = self.auth.pending.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(p) = pending.get_mut(name) {
            p.0 = p.0.saturating_sub(1);
            p.1 = p.1.saturating_sub(self.bytes);
            if p.0 == 0 {
                pending.remove(name);
            }
        }
    }
}

impl Auth {
    /// Checks the caller's quotas for one more job storing `bytes`:
    /// `usage` gives the (active jobs, stored bytes) its registered jobs
    /// hold; a refusal is counted in `metrics`. The admission holds the new
    /// job's share until dropped.
    pub fn admit(
        &self,
        caller: &Caller,
        bytes: u64,
        usage: impl FnOnce(&str) -> (u64, u64),
        metrics: &Metrics,
    ) -> Result<Admission<'_>, Problem> {
        let Some(key) = &caller.0 else {
            return Ok(Admission {
                auth: self,
                name: None,
                bytes: 0,
            });
        };
        let q = key.quotas;
        let (active, stored) = usage(&key.name);
        let mut pending = self.pending.lock().unwrap_or_else(|p| p.into_inner());
        let p = pending.entry(key.name.clone()).or_insert((0, 0));
        if active + p.0 >= u64::from(q.max_active_jobs) {
            let problem = Problem::new(
                ProblemKind::QuotaExceeded,
                format!(
                    "the key {:?} has {} jobs queued or running, its limit (max_active_jobs); \
                     retry when one has finished",
                    key.name, q.max_active_jobs
                ),
            )
            .with_retry_after(ACTIVE_RETRY_SECS);
            metrics.refused(Refusal::ActiveJobs);
            return Err(problem);
        }
        if stored + p.1 + bytes > q.max_stored_bytes {
            let problem = Problem::new(
                ProblemKind::QuotaExceeded,
                format!(
                    "the key {:?} stores {} bytes; {} more would pass its limit of {} \
                     (max_stored_bytes): delete finished jobs or wait until they expire",
                    key.name,
                    stored + p.1,
                    bytes,
                    q.max_stored_bytes
                ),
            );
            metrics.refused(Refusal::StoredBytes);
            return Err(problem);
        }
        p.0 += 1;
        p.1 += bytes;
        Ok(Admission {
            auth: self,
            name: Some(key.name.clone()),
            bytes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(lines: &str) -> Result<KeySet, KeyFileError> {
        KeySet::parse(Path::new("keys"), lines)
    }

    #[test]
    fn a_key_matches_only_its_own_hash() {
        let key = generate_key().unwrap();
        let line = format!(
            "# comment\n\n{{\"name\":\"a\",\"sha256\":\"{}\",\"burst\":3}}\n",
            hex::encode(digest(&key))
        );
        let s = set(&line).unwrap();
        let k = s.authenticate(&key).unwrap();
        assert_eq!(k.name, "a");
        assert_eq!(k.quotas.burst, 3);
        assert_eq!(k.quotas.max_active_jobs, DEFAULT_MAX_ACTIVE_JOBS);
        assert!(s.authenticate(&format!("{key}x")).is_none());
        assert!(s.authenticate("").is_none());
    }

    #[test]
    fn bad_lines_are_named() {
        let h = "0".repeat(64);
        for (text, want) in [
            ("{\"name\":\"a\"}".to_string(), ":1: not a key entry"),
            (
                format!("{{\"name\":\"a b\",\"sha256\":\"{h}\"}}"),
                ":1: a name",
            ),
            (
                "{\"name\":\"a\",\"sha256\":\"xyz\"}".to_string(),
                ":1: sha256",
            ),
            (
                format!(
                    "{{\"name\":\"a\",\"sha256\":\"{h}\"}}\n{{\"name\":\"a\",\"sha256\":\"{h}\"}}"
                ),
                ":2: the name \"a\" is used twice",
            ),
            (
                format!("{{\"name\":\"a\",\"sha256\":\"{h}\",\"requests_per_second\":0}}"),
                ":1: every limit",
            ),
            (
                format!("{{\"name\":\"a\",\"sha256\":\"{h}\",\"quota\":1}}"),
                ":1: not a key entry: unknown field",
            ),
        ] {
            let e = set(&text).unwrap_err().to_string();
            assert!(e.contains(want), "{e:?} should contain {want:?}");
        }
    }

    #[test]
    fn the_bucket_refills_at_the_rate() {
        let s = set(&format!(
            "{{\"name\":\"a\",\"sha256\":\"{}\",\"requests_per_second\":2,\"burst\":2}}",
            "0".repeat(64)
        ))
        .unwrap();
        let auth = Auth {
            path: None,
            keys: RwLock::new(Arc::new(KeySet::default())),
            buckets: Mutex::new(HashMap::new()),
            pending: Mutex::new(HashMap::new()),
        };
        let k = &s.keys[0];
        let t0 = Instant::now();
        assert!(auth.take(k, t0).is_ok());
        assert!(auth.take(k, t0).is_ok());
        assert_eq!(auth.take(k, t0), Err(1));
        assert!(auth
            .take(k, t0 + std::time::Duration::from_millis(500))
            .is_ok());
        assert!(auth
            .take(k, t0 + std::time::Duration::from_millis(500))
            .is_err());
    }

    #[test]
    fn new_keys_are_appended_and_names_stay_unique() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("keys.jsonl");
        let entry = |name: &str| KeyLine {
            name: name.into(),
            sha256: String::new(),
            max_active_jobs: Some(2),
            requests_per_second: None,
            burst: None,
            max_stored_bytes: None,
        };
        let a = append_new_key(&file, entry("alice")).unwrap();
        let b = append_new_key(&file, entry("bob")).unwrap();
        assert!(a.starts_with(KEY_PREFIX) && a.len() == KEY_PREFIX.len() + 64);
        let s = KeySet::load(&file).unwrap();
        assert_eq!(s.authenticate(&a).unwrap().name, "alice");
        assert_eq!(s.authenticate(&b).unwrap().quotas.max_active_jobs, 2);
        let e = append_new_key(&file, entry("alice"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("exists"), "{e}");
        assert!(!std::fs::read_to_string(&file).unwrap().contains(&a));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&file).unwrap().permissions().mode();
            assert_eq!(mode & 0o077, 0, "the key file is private");
        }
    }
}
