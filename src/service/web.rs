//! The web page at `/`: drop a mesh, watch the job, compare input and
//! output in 3D and read the statistics as plots. It is a client of the job
//! API like any other; this module only serves its files.
//!
//! Every file is embedded in the binary (`include_bytes!`), so the page
//! works offline and `isoremesh serve` needs neither Node.js nor network.
//! The page is plain ES modules (`web/*.js`) and three.js, vendored
//! unchanged from its npm package (`web/vendor/three`, with its licence).
//! The one inline element is the import map that lets three.js's add-ons
//! import `three`; the Content-Security-Policy allows it by its SHA-256
//! and allows nothing else inline: scripts, styles, images and connections
//! come from this origin only (plus `blob:` and `data:` for the textures
//! and buffers of the user's own files).
//!
//! Files are sent gzip-compressed when the client accepts it (compressed
//! once, on first request), with a strong ETag and `Cache-Control: no-cache`
//! so that a reload costs one 304 per file.

use std::io::Write;
use std::sync::OnceLock;

use axum::extract::Path;
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use base64::Engine;
use sha2::{Digest, Sha256};

use super::problem::{Problem, ProblemKind};
use super::server::AppState;
use crate::io::Format;
use crate::params::Params;

/// One embedded file.
struct Asset {
    /// Path below `/assets/` (the page itself is `index.html`, served at `/`).
    path: &'static str,
    /// Media type.
    mime: &'static str,
    bytes: &'static [u8],
}

macro_rules! asset {
    ($path:literal, $mime:expr) => {
        Asset {
            path: $path,
            mime: $mime,
            bytes: include_bytes!(concat!("web/", $path)),
        }
    };
}

/// The media type of scripts.
const JS: &str = "text/javascript; charset=utf-8";

/// Every file of the page.
static ASSETS: &[Asset] = &[
    asset!("index.html", "text/html; charset=utf-8"),
    asset!("style.css", "text/css; charset=utf-8"),
    asset!("app.js", JS),
    asset!("api.js", JS),
    asset!("viewer.js", JS),
    asset!("meshes.js", JS),
    asset!("quality.js", JS),
    asset!("lod.js", JS),
    asset!("plots.js", JS),
    asset!("vendor/three/LICENSE", "text/plain; charset=utf-8"),
    asset!("vendor/three/build/three.module.js", JS),
    asset!("vendor/three/build/three.core.js", JS),
    asset!("vendor/three/examples/jsm/controls/OrbitControls.js", JS),
    asset!("vendor/three/examples/jsm/loaders/GLTFLoader.js", JS),
    asset!("vendor/three/examples/jsm/loaders/OBJLoader.js", JS),
    asset!("vendor/three/examples/jsm/loaders/MTLLoader.js", JS),
    asset!("vendor/three/examples/jsm/loaders/STLLoader.js", JS),
    asset!("vendor/three/examples/jsm/loaders/PLYLoader.js", JS),
    asset!("vendor/three/examples/jsm/utils/BufferGeometryUtils.js", JS),
    asset!("vendor/three/examples/jsm/utils/SkeletonUtils.js", JS),
];

/// The routes of the page: `/` and `/assets/{path}`. They are outside the
/// job API (`openapi.yaml` says so) and carry the page's security headers.
pub fn router() -> Router<AppState> {
    Router::new()
        .route("/", get(index))
        .route("/assets/{*path}", get(asset))
}

/// The Content-Security-Policy of the page: own origin only, and the import
/// map by its hash.
pub fn content_security_policy() -> &'static str {
    static CSP: OnceLock<String> = OnceLock::new();
    CSP.get_or_init(|| {
        let html = std::str::from_utf8(ASSETS[0].bytes).unwrap_or("");
        let hash = import_map(html)
            .map(|m| {
                let digest = Sha256::digest(m.as_bytes());
                format!(
                    " 'sha256-{}'",
                    base64::engine::general_purpose::STANDARD.encode(digest)
                )
            })
            .unwrap_or_default();
        format!(
            "default-src 'none'; script-src 'self'{hash}; style-src 'self'; \
             img-src 'self' blob: data:; connect-src 'self' blob: data:; \
             base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
        )
    })
}

/// The text of the page's `<script type="importmap">`, exactly as the
/// browser hashes it.
fn import_map(html: &str) -> Option<&str> {
    const OPEN: &str = "<script type=\"importmap\">";
    let start = html.find(OPEN)? + OPEN.len();
    let len = html[start..].find("</script>")?;
    Some(&html[start..start + len])
}

/// What one file's responses need, computed once.
struct Prepared {
    etag: String,
    gzip: Vec<u8>,
}

fn prepared(i: usize, bytes: &[u8]) -> &'static Prepared {
    static CACHE: OnceLock<Vec<OnceLock<Prepared>>> = OnceLock::new();
    let cells = CACHE.get_or_init(|| (0..=ASSETS.len()).map(|_| OnceLock::new()).collect());
    cells[i].get_or_init(|| {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        let gzip = match enc.write_all(bytes).and_then(|()| enc.finish()) {
            Ok(z) if z.len() < bytes.len() => z,
            _ => Vec::new(),
        };
        Prepared {
            etag: format!("\"{}\"", hex::encode(Sha256::digest(bytes))),
            gzip,
        }
    })
}

/// The page's security headers, set on every page response.
fn security_headers(h: &mut HeaderMap) {
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(content_security_policy()),
    );
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
}

/// A response for file `i` (its cache slot), honouring `If-None-Match` and
/// `Accept-Encoding: gzip`.
fn serve(i: usize, mime: &'static str, bytes: &'static [u8], req: &HeaderMap) -> Response {
    let p = prepared(i, bytes);
    let not_modified = req
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == p.etag));
    let gzip_ok = !p.gzip.is_empty()
        && req
            .get(header::ACCEPT_ENCODING)
            .and_then(|v| v.to_str().ok())
            .is_some_and(accepts_gzip);
    let mut resp = if not_modified {
        StatusCode::NOT_MODIFIED.into_response()
    } else if gzip_ok {
        p.gzip.clone().into_response()
    } else {
        bytes.into_response()
    };
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(mime));
    if gzip_ok && !not_modified {
        h.insert(header::CONTENT_ENCODING, HeaderValue::from_static("gzip"));
    }
    if let Ok(v) = HeaderValue::from_str(&p.etag) {
        h.insert(header::ETAG, v);
    }
    h.insert(header::VARY, HeaderValue::from_static("accept-encoding"));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    security_headers(h);
    resp
}

/// Whether an `Accept-Encoding` value admits gzip (not with `q=0`).
fn accepts_gzip(value: &str) -> bool {
    value.split(',').any(|item| {
        let mut parts = item.split(';');
        let coding = parts.next().unwrap_or("").trim();
        let q_zero = parts.any(|p| {
            p.trim()
                .strip_prefix("q=")
                .and_then(|q| q.trim().parse::<f64>().ok())
                == Some(0.0)
        });
        (coding.eq_ignore_ascii_case("gzip") || coding == "*") && !q_zero
    })
}

/// `GET /`: the page.
async fn index(headers: HeaderMap) -> Response {
    let a = &ASSETS[0];
    serve(0, a.mime, a.bytes, &headers)
}

/// The form's defaults and choices, from the same types the API parses, so
/// the page cannot drift from them.
fn defaults_json() -> &'static [u8] {
    static JSON: OnceLock<Vec<u8>> = OnceLock::new();
    JSON.get_or_init(|| {
        let formats: Vec<&str> = Format::ALL.iter().map(|f| f.extension()).collect();
        serde_json::to_vec(&serde_json::json!({
            "params": Params::default(),
            "formats": formats,
        }))
        .unwrap_or_default()
    })
}

/// `GET /assets/{path}`: one embedded file, or `defaults.json`.
async fn asset(Path(path): Path<String>, headers: HeaderMap) -> Response {
    if path == "defaults.json" {
        return serve(ASSETS.len(), "application/json", defaults_json(), &headers);
    }
    match ASSETS
        .iter()
        .enumerate()
        .skip(1)
        .find(|(_, a)| a.path == path)
    {
        Some((i, a)) => serve(i, a.mime, a.bytes, &headers),
        None => {
            let mut resp = Problem::new(ProblemKind::NotFound, format!("no page asset {path:?}"))
                .into_response();
            security_headers(resp.headers_mut());
            resp
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_import_map_is_found_and_hashed_into_the_policy() {
        let html = std::str::from_utf8(ASSETS[0].bytes).unwrap();
        let map = import_map(html).expect("index.html has an import map");
        assert!(map.contains("\"three\""));
        let csp = content_security_policy();
        assert!(csp.contains("'sha256-"));
        assert!(!csp.contains("unsafe-inline"));
    }

    #[test]
    fn vendored_files_are_the_ones_vendor_md_pins() {
        let pins = include_str!("web/vendor/VENDOR.md");
        let mut checked = 0;
        for line in pins.lines() {
            let Some((sha, path)) = line.split_once("  ") else {
                continue;
            };
            if sha.len() != 64 || !sha.bytes().all(|b| b.is_ascii_hexdigit()) {
                continue;
            }
            let want = format!("vendor/three/{path}");
            let a = ASSETS.iter().find(|a| a.path == want).expect(&want);
            assert_eq!(hex::encode(Sha256::digest(a.bytes)), sha, "{want}");
            checked += 1;
        }
        let vendored = ASSETS
            .iter()
            .filter(|a| a.path.starts_with("vendor/"))
            .count();
        assert_eq!(checked, vendored);
    }

    #[test]
    fn gzip_is_accepted_unless_refused() {
        assert!(accepts_gzip("gzip, deflate, br"));
        assert!(accepts_gzip("br;q=1.0, gzip;q=0.8"));
        assert!(accepts_gzip("*"));
        assert!(!accepts_gzip("gzip;q=0"));
        assert!(!accepts_gzip("br, deflate"));
    }

    #[test]
    fn every_asset_path_is_unique_and_every_script_is_javascript() {
        let mut paths: Vec<_> = ASSETS.iter().map(|a| a.path).collect();
        paths.sort_unstable();
        paths.dedup();
        assert_eq!(paths.len(), ASSETS.len());
        for a in ASSETS {
            assert_eq!(a.path.ends_with(".js"), a.mime == JS, "{}", a.path);
        }
    }
}
