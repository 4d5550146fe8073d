//! The route table and [`app`]. The router is built from [`routes`], the
//! same table the contract test compares with `openapi.yaml`, so the two
//! cannot drift apart silently. The web page's routes ([`super::web`]) are
//! merged in beside them; they are outside the API. Layers: a request id (`x-request-id`, taken
//! from the client or generated) set first, a trace span carrying it around
//! every request, the id echoed in the response, and the body limit that the
//! multipart parser honours. The `/v1` routes also pass
//! [`super::auth::require_key`] (API key and rate limit), and every
//! response is logged once, a problem with its type and field.

use std::net::SocketAddr;
use std::time::Duration;

use axum::extract::{ConnectInfo, DefaultBodyLimit};
use axum::http::{HeaderName, Method, Request};
use axum::middleware;
use axum::response::Response;
use axum::routing::{delete, get, post, MethodRouter};
use axum::Router;
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::trace::TraceLayer;

use super::handlers;
use super::problem::Logged;
use super::server::AppState;

/// One route: method, path (axum syntax, `{id}`), handler.
pub struct Route {
    /// The HTTP method.
    pub method: Method,
    /// The path template, as in `openapi.yaml`.
    pub path: &'static str,
    handler: MethodRouter<AppState>,
}

/// Every route the service answers.
pub fn routes() -> Vec<Route> {
    let r = |method: Method, path: &'static str, handler: MethodRouter<AppState>| Route {
        method,
        path,
        handler,
    };
    vec![
        r(Method::POST, "/v1/jobs", post(handlers::submit)),
        r(Method::GET, "/v1/jobs", get(handlers::list)),
        r(Method::GET, "/v1/jobs/{id}", get(handlers::get_job)),
        r(Method::DELETE, "/v1/jobs/{id}", delete(handlers::delete)),
        r(Method::GET, "/v1/jobs/{id}/result", get(handlers::result)),
        r(Method::POST, "/v1/jobs/{id}/cancel", post(handlers::cancel)),
        r(Method::GET, "/healthz", get(handlers::healthz)),
        r(Method::GET, "/readyz", get(handlers::readyz)),
        r(Method::GET, "/metrics", get(handlers::metrics)),
        r(Method::GET, "/openapi.yaml", get(handlers::openapi)),
    ]
}

/// (method, path) of every route, for the contract test.
pub fn route_table() -> Vec<(Method, &'static str)> {
    routes().into_iter().map(|r| (r.method, r.path)).collect()
}

/// The service's router over `state`.
pub fn app(state: AppState) -> Router {
    let body_limit = usize::try_from(state.config.max_body_bytes).unwrap_or(usize::MAX);
    let request_id = HeaderName::from_static("x-request-id");
    let (api, open): (Vec<Route>, Vec<Route>) = routes()
        .into_iter()
        .partition(|r| r.path.starts_with("/v1/"));
    let add = |router: Router<AppState>, r: Route| router.route(r.path, r.handler);
    let api = api
        .into_iter()
        .fold(Router::new(), add)
        .route_layer(middleware::from_fn_with_state(
            state.clone(),
            super::auth::require_key,
        ));
    let router = open.into_iter().fold(api, add).merge(super::web::router());
    router
        .fallback(handlers::not_found)
        .method_not_allowed_fallback(handlers::method_not_allowed)
        .with_state(state)
        .layer(DefaultBodyLimit::max(body_limit))
        .layer(PropagateRequestIdLayer::new(request_id.clone()))
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(|req: &Request<_>| {
                    let id = req
                        .headers()
                        .get("x-request-id")
                        .and_then(|v| v.to_str().ok())
                        .unwrap_or("-");
                    let peer = req
                        .extensions()
                        .get::<ConnectInfo<SocketAddr>>()
                        .map(|c| c.0.to_string())
                        .unwrap_or_else(|| "-".into());
                    // Client-supplied values go in as Debug: quoted and
                    // escaped, so they cannot forge fields or lines.
                    tracing::info_span!(
                        "request",
                        request_id = ?id,
                        peer = %peer,
                        method = %req.method(),
                        path = ?req.uri().path()
                    )
                })
                .on_response(log_response),
        )
        .layer(SetRequestIdLayer::new(request_id, MakeRequestUuid))
}

/// One line per response, in the request's span (request id, peer, method,
/// path): a problem answer names its type and field, so that a refusal can
/// be traced to the rule and the client that met it.
fn log_response(resp: &Response, latency: Duration, _span: &tracing::Span) {
    let status = resp.status().as_u16();
    let micros = latency.as_micros() as u64;
    match resp.extensions().get::<Logged>() {
        Some(p) if status >= 500 => tracing::warn!(
            status,
            latency_us = micros,
            problem = %p.slug,
            field = ?p.field.as_deref().unwrap_or("-"),
            "request failed"
        ),
        Some(p) => tracing::info!(
            status,
            latency_us = micros,
            problem = %p.slug,
            field = ?p.field.as_deref().unwrap_or("-"),
            "request refused"
        ),
        None => tracing::info!(status, latency_us = micros, "request done"),
    }
}
