//! Receiving a submission: the body is read frame by frame under the size
//! limit and the upload deadline (so a slow or endless upload cannot hold
//! memory or a connection forever), then split into the mesh, the params and
//! any external glTF buffers. Multipart bodies carry a `mesh` file part, an
//! optional `params` JSON part and buffer parts named by their `uri`; any
//! other body is the mesh itself, with its format from `Content-Type` or the
//! content and its params from the query string.
//!
//! Globally, an [`UploadGate`] bounds the uploads in flight and their bytes,
//! so that concurrent uploads cannot together hold more memory than the
//! operator allowed: past either bound a submission gets a 503 with
//! `Retry-After` at once, or as soon as its bytes would pass the budget.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::{FromRequest, Multipart, Query, Request};
use axum::http::header;
use http_body_util::BodyExt;
use sha2::{Digest, Sha256};

use super::config::ServiceConfig;
use super::metrics::{Metrics, Refusal};
use super::problem::{Problem, ProblemKind};
use crate::io::Format;
use crate::params::Params;

/// A received submission, not yet parsed as a mesh.
#[derive(Debug)]
pub struct Upload {
    /// The mesh file's bytes.
    pub mesh: Bytes,
    /// The mesh part's file name, if any.
    pub file_name: Option<String>,
    /// The format named by the mesh's media type, if it names one.
    pub format_hint: Option<Format>,
    /// The parameters.
    pub params: Params,
    /// External glTF buffers: (uri, bytes), in the order received.
    pub buffers: Vec<(String, Vec<u8>)>,
    /// SHA-256 (hex) over the mesh, its name and format hint, the buffers
    /// and the normalised params: what an `Idempotency-Key` is bound to.
    /// Multipart boundaries and part order of the params do not change it.
    pub fingerprint: String,
    /// Its share of the global upload budget, held while the upload is.
    pub permit: UploadPermit,
}

/// Seconds a client refused at the global upload limits should wait.
const UPLOADS_RETRY_SECS: u64 = 2;

/// The global bounds on uploads in flight (being received, parsed and
/// stored) and on their bytes.
#[derive(Debug)]
pub struct UploadGate {
    max_uploads: u64,
    max_bytes: u64,
    uploads: AtomicU64,
    bytes: AtomicU64,
}

/// One upload's share of an [`UploadGate`], returned when dropped.
#[derive(Debug)]
pub struct UploadPermit {
    gate: Arc<UploadGate>,
    bytes: u64,
}

impl Drop for UploadPermit {
    fn drop(&mut self) {
        self.gate.bytes.fetch_sub(self.bytes, Ordering::SeqCst);
        self.gate.uploads.fetch_sub(1, Ordering::SeqCst);
    }
}

fn busy(why: &str) -> Problem {
    Problem::new(ProblemKind::UploadsBusy, why.to_string()).with_retry_after(UPLOADS_RETRY_SECS)
}

impl UploadGate {
    /// A gate admitting `max_uploads` uploads of `max_bytes` bytes in all.
    pub fn new(max_uploads: u64, max_bytes: u64) -> Arc<Self> {
        Arc::new(Self {
            max_uploads,
            max_bytes,
            uploads: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
        })
    }

    /// (uploads, bytes) in flight now.
    pub fn in_flight(&self) -> (u64, u64) {
        (
            self.uploads.load(Ordering::SeqCst),
            self.bytes.load(Ordering::SeqCst),
        )
    }

    /// Admits one more upload, or refuses it when all slots are taken.
    fn enter(self: &Arc<Self>) -> Option<UploadPermit> {
        let taken = self
            .uploads
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < self.max_uploads).then_some(n + 1)
            });
        taken.ok().map(|_| UploadPermit {
            gate: Arc::clone(self),
            bytes: 0,
        })
    }
}

impl UploadPermit {
    /// Counts `n` more bytes of this upload; `false` (nothing counted) when
    /// they would pass the global byte budget.
    fn grow(&mut self, n: u64) -> bool {
        let max = self.gate.max_bytes;
        let ok = self
            .gate
            .bytes
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |b| {
                (b + n <= max).then_some(b + n)
            })
            .is_ok();
        if ok {
            self.bytes += n;
        }
        ok
    }
}

fn too_large(limit: u64) -> Problem {
    Problem::new(
        ProblemKind::BodyTooLarge,
        format!("the request body exceeds the limit of {limit} bytes"),
    )
    .with_field("body")
}

/// How much of an oversized body is still read (and discarded) before the
/// 413 is sent. A server that answers and closes while the client is still
/// writing makes many clients report a broken pipe instead of the answer;
/// draining a bounded tail lets them read the problem document.
const LINGER_BYTES: u64 = 1 << 20;

/// How long a refused upload's tail is still read before the answer.
const LINGER_TIME: std::time::Duration = std::time::Duration::from_secs(2);

/// Reads and discards up to [`LINGER_BYTES`] of a refused body, for at most
/// [`LINGER_TIME`], so that the client is done writing (and reads the
/// answer) when the body was small, without holding memory or waiting long
/// for a large or stalled one.
async fn drain(mut body: Body) {
    let tail = async {
        let mut seen = 0u64;
        while let Some(Ok(frame)) = body.frame().await {
            seen += frame.data_ref().map_or(0, |d| d.len() as u64);
            if seen > LINGER_BYTES {
                break;
            }
        }
    };
    let _ = tokio::time::timeout(LINGER_TIME, tail).await;
}

/// Reads the whole body, failing past `limit` bytes (after draining up to
/// [`LINGER_BYTES`] more) or when the global budget is spent. The budget
/// counts the buffer's capacity, not only its length: a body of declared
/// length is read into one allocation of that size, reserved up front, and
/// a chunked one grows by doubling, each growth counted before it happens.
async fn read_limited(
    mut body: Body,
    limit: u64,
    declared: Option<u64>,
    permit: &mut UploadPermit,
    metrics: &Metrics,
) -> Result<Bytes, Problem> {
    let refuse = |permit: &UploadPermit| {
        metrics.refused(Refusal::UploadBytesInFlight);
        busy(&format!(
            "the uploads in flight hold the server's budget of {} bytes; retry later",
            permit.gate.max_bytes
        ))
    };
    let mut buf: Vec<u8> = Vec::new();
    if let Some(n) = declared.filter(|&n| n <= limit) {
        if !permit.grow(n) {
            drain(body).await;
            return Err(refuse(permit));
        }
        buf.reserve_exact(n as usize);
    }
    let mut seen: u64 = 0;
    while let Some(frame) = body.frame().await {
        let frame = frame.map_err(|e| {
            Problem::new(
                ProblemKind::InvalidRequest,
                format!("the body could not be read: {e}"),
            )
        })?;
        if let Ok(data) = frame.into_data() {
            seen += data.len() as u64;
            if seen > limit + LINGER_BYTES {
                break;
            }
            if seen <= limit {
                let need = buf.len() + data.len();
                if need > buf.capacity() {
                    let grown = need.max(buf.capacity() * 2).min(limit as usize);
                    if !permit.grow((grown - buf.capacity()) as u64) {
                        drop(std::mem::take(&mut buf));
                        drain(body).await;
                        return Err(refuse(permit));
                    }
                    buf.reserve_exact(grown - buf.len());
                }
                buf.extend_from_slice(&data);
            } else {
                buf = Vec::new();
            }
        }
    }
    if seen > limit {
        return Err(too_large(limit));
    }
    Ok(Bytes::from(buf))
}

fn bad_request(detail: impl Into<String>) -> Problem {
    Problem::new(ProblemKind::InvalidRequest, detail)
}

/// Reads and splits a submission under the gate's global bounds.
pub async fn read_upload(
    req: Request,
    cfg: &ServiceConfig,
    gate: &Arc<UploadGate>,
    metrics: &Metrics,
) -> Result<Upload, Problem> {
    let (parts, body) = req.into_parts();
    let declared = parts
        .headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if declared.is_some_and(|n| n > cfg.max_body_bytes + LINGER_BYTES) {
        return Err(too_large(cfg.max_body_bytes));
    }
    let Some(mut permit) = gate.enter() else {
        metrics.refused(Refusal::UploadsInFlight);
        drain(body).await;
        return Err(busy(&format!(
            "{} uploads are in flight, the server's limit; retry later",
            gate.max_uploads
        )));
    };
    let read = read_limited(body, cfg.max_body_bytes, declared, &mut permit, metrics);
    let bytes = tokio::time::timeout(cfg.upload_timeout(), read)
        .await
        .map_err(|_| {
            Problem::new(
                ProblemKind::UploadTimeout,
                format!(
                    "the upload did not complete within {} s",
                    cfg.upload_timeout_secs
                ),
            )
        })??;
    let content_type = parts
        .headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    let multipart = content_type
        .split(';')
        .next()
        .is_some_and(|m| m.trim().eq_ignore_ascii_case("multipart/form-data"));
    let query = parts.uri.query().unwrap_or("").to_string();
    let (mesh, file_name, format_hint, params, buffers) = if multipart {
        if !query.is_empty() {
            return Err(bad_request(
                "with a multipart body, send the parameters in the `params` part, not in the query string",
            )
            .with_field("params"));
        }
        let req = Request::from_parts(parts, Body::from(bytes));
        read_multipart(req).await?
    } else {
        let pairs = Query::<Vec<(String, String)>>::try_from_uri(&parts.uri)
            .map_err(|e| bad_request(format!("the query string cannot be parsed: {e}")))?
            .0;
        let params = Params::from_query(&pairs)?;
        if bytes.is_empty() {
            return Err(bad_request("the body is empty; send a mesh file").with_field("mesh"));
        }
        let hint = Format::from_mime(&content_type);
        (bytes, None, hint, params, Vec::new())
    };
    let fingerprint = fingerprint(&mesh, file_name.as_deref(), format_hint, &params, &buffers);
    Ok(Upload {
        mesh,
        file_name,
        format_hint,
        params,
        buffers,
        fingerprint,
        permit,
    })
}

type Split = (
    Bytes,
    Option<String>,
    Option<Format>,
    Params,
    Vec<(String, Vec<u8>)>,
);

async fn read_multipart(req: Request) -> Result<Split, Problem> {
    let mp_err = |e: axum::extract::multipart::MultipartError| {
        bad_request(format!(
            "the multipart body is malformed: {}",
            e.body_text()
        ))
    };
    let mut mp = Multipart::from_request(req, &())
        .await
        .map_err(|e| bad_request(format!("the multipart body is malformed: {e}")))?;
    let mut mesh = None;
    let mut params = None;
    let mut buffers: Vec<(String, Vec<u8>)> = Vec::new();
    while let Some(field) = mp.next_field().await.map_err(mp_err)? {
        let name = field.name().unwrap_or("").to_string();
        let file_name = field.file_name().map(str::to_string);
        let hint = field.content_type().and_then(Format::from_mime);
        let data = field.bytes().await.map_err(mp_err)?;
        match name.as_str() {
            "mesh" => {
                if mesh.is_some() {
                    return Err(bad_request("more than one `mesh` part").with_field("mesh"));
                }
                mesh = Some((data, file_name, hint));
            }
            "params" => {
                if params.is_some() {
                    return Err(bad_request("more than one `params` part").with_field("params"));
                }
                params = Some(Params::from_json_bytes(&data)?);
            }
            "" => return Err(bad_request("a multipart part has no name")),
            uri => {
                if buffers.iter().any(|(u, _)| u == uri) {
                    return Err(
                        bad_request(format!("more than one part named {uri:?}")).with_field(uri)
                    );
                }
                buffers.push((uri.to_string(), data.to_vec()));
            }
        }
    }
    let Some((data, file_name, hint)) = mesh else {
        return Err(
            bad_request("no `mesh` part: send the mesh file as a part named `mesh`")
                .with_field("mesh"),
        );
    };
    if data.is_empty() {
        return Err(bad_request("the `mesh` part is empty").with_field("mesh"));
    }
    Ok((data, file_name, hint, params.unwrap_or_default(), buffers))
}

fn fingerprint(
    mesh: &[u8],
    file_name: Option<&str>,
    hint: Option<Format>,
    params: &Params,
    buffers: &[(String, Vec<u8>)],
) -> String {
    let mut h = Sha256::new();
    let mut field = |bytes: &[u8]| {
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(b"isoremesh-submission-v1");
    field(file_name.unwrap_or("").as_bytes());
    field(hint.map(|f| f.extension()).unwrap_or("").as_bytes());
    field(&serde_json::to_vec(params).unwrap_or_default());
    field(mesh);
    let mut sorted: Vec<_> = buffers.iter().collect();
    sorted.sort_by(|a, b| a.0.cmp(&b.0));
    for (uri, bytes) in sorted {
        field(uri.as_bytes());
        field(bytes);
    }
    hex::encode(h.finalize())
}
