//! The HTTP service behind `isoremesh serve`: a thin shell that turns REST
//! calls into [`crate::pipeline`] jobs and back. Uploads are validated before
//! they are queued, jobs run on a fixed pool of blocking worker threads fed
//! by a bounded queue, and everything a job needs or produces lives in a data
//! directory so that results survive restarts (even `kill -9`) and
//! interrupted jobs run again. `openapi.yaml` at the repository root is the
//! contract; `tests/service_contract.rs` checks the router and real response
//! bodies against it. Shape after mini-redis (`run(listener, shutdown)`) and
//! the axum examples (`app(state) -> Router`, one error type rendered once).
//!
//! | module | owns |
//! |---|---|
//! | [`server`] | the [`Service`] object, [`serve`] and [`run`] |
//! | [`auth`] | API keys, the caller of a request, per-key rate limits and quotas |
//! | [`config`] | flags and `ISOREMESH_*` variables, limits |
//! | [`connections`] | the accept loop: connection cap, request-head deadline, graceful close |
//! | [`routes`] | the route table and [`app`] |
//! | [`handlers`] | one function per endpoint |
//! | [`upload`] | reading a submission under size and time limits |
//! | [`params`] | job parameters → [`crate::remesh::RemeshOptions`], the output estimate |
//! | [`dto`] | the JSON documents |
//! | [`prepared`] | parsed inputs handed from submit to the worker, under a byte budget |
//! | [`jobs`] | job records, states, the registry |
//! | [`queue`] | bounded queue, worker threads, running a job |
//! | [`store`] | the data directory, atomic writes |
//! | [`bundle`] | `bundle=zip` downloads: a result and its companion files in one archive |
//! | [`problem`] | RFC 9457 problem details |
//! | [`metrics`] | Prometheus counters and histogram |
//! | [`telemetry`] | tracing setup, request ids, panic hook |
//! | [`web`] | the web page at `/` and its embedded files |

pub mod auth;
pub mod bundle;
pub mod config;
pub mod connections;
pub mod dto;
pub mod handlers;
pub mod jobs;
pub mod metrics;
pub mod params;
pub mod prepared;
pub mod problem;
pub mod queue;
pub mod routes;
pub mod server;
pub mod store;
pub mod telemetry;
pub mod upload;
pub mod web;

pub use config::ServiceConfig;
pub use routes::app;
pub use server::{run, serve, AppState, Service, StartError};
