//! Job parameters as the service receives them: [`Params`] read strictly
//! from the `params` multipart part (JSON) or the query string of a raw-body
//! upload. An unknown or repeated name, a mistyped value or an option the
//! engine rejects is a 422 naming the field. The output estimate that guards memory,
//! area / (√3/4 · L²), is checked here before a job is queued.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use super::problem::{Problem, ProblemKind};
use crate::params::{Params, PARAM_NAMES};
use crate::remesh::{estimated_faces, RemeshError, RemeshOptions, Sizing};

/// The largest `params` part, or query string of parameters: every
/// parameter fits in a few hundred bytes, so anything near this is not a
/// parameter set, and is refused before it is parsed.
pub const MAX_PARAMS_BYTES: usize = 64 * 1024;

fn check_params_size(len: usize) -> Result<(), Problem> {
    if len > MAX_PARAMS_BYTES {
        return Err(Problem::new(
            ProblemKind::BodyTooLarge,
            format!("the parameters are {len} bytes; at most {MAX_PARAMS_BYTES} are accepted"),
        )
        .with_field("params"));
    }
    Ok(())
}

fn bad(field: &str, message: impl std::fmt::Display) -> Problem {
    Problem::new(ProblemKind::InvalidParameter, format!("{field}: {message}")).with_field(field)
}

impl Params {
    /// Parameters from a JSON object (the `params` part). `null` means "use
    /// the default".
    pub fn from_json(v: &Value) -> Result<Self, Problem> {
        match v {
            Value::Object(map) => Self::from_map(map),
            _ => Err(Problem::new(
                ProblemKind::InvalidParameter,
                "params must be a JSON object",
            )
            .with_field("params")),
        }
    }

    /// Parameters from the bytes of the `params` part: a JSON object in
    /// which every name appears once. A JSON parser keeps the last of two
    /// equal names, so a repeated name (a merge gone wrong, a typo'd
    /// duplicate) would silently drop a value; it is refused with a 422
    /// naming it, as a repeated query parameter is.
    pub fn from_json_bytes(data: &[u8]) -> Result<Self, Problem> {
        check_params_size(data.len())?;
        let v: Value = serde_json::from_slice(data).map_err(|e| {
            Problem::new(
                ProblemKind::InvalidRequest,
                format!("the `params` part is not valid JSON: {e}"),
            )
            .with_field("params")
        })?;
        if let Ok(TopLevelKeys(Some(dup))) = serde_json::from_slice::<TopLevelKeys>(data) {
            return Err(bad(&dup, "given more than once"));
        }
        Self::from_json(&v)
    }

    /// Parameters from `name=value` pairs (the query string). Numbers and
    /// booleans are read as JSON; anything else is a string.
    pub fn from_query(pairs: &[(String, String)]) -> Result<Self, Problem> {
        check_params_size(pairs.iter().map(|(k, v)| k.len() + v.len() + 2).sum())?;
        let mut map = Map::new();
        for (k, raw) in pairs {
            let v = match serde_json::from_str::<Value>(raw) {
                Ok(v @ (Value::Number(_) | Value::Bool(_) | Value::Null)) => v,
                _ => Value::String(raw.clone()),
            };
            if map.insert(k.clone(), v).is_some() {
                return Err(bad(k, "given more than once"));
            }
        }
        Self::from_map(&map)
    }

    /// Every name is checked against [`PARAM_NAMES`] and its value read
    /// alone, so a problem names its field; the values then fill
    /// [`Params`] in one read.
    fn from_map(map: &Map<String, Value>) -> Result<Self, Problem> {
        let mut given = Map::new();
        for (k, v) in map {
            if !PARAM_NAMES.contains(&k.as_str()) {
                return Err(unknown(k));
            }
            if v.is_null() {
                continue;
            }
            let one = Value::Object(Map::from_iter([(k.clone(), v.clone())]));
            Params::deserialize(&one).map_err(|e| bad(k, e))?;
            given.insert(k.clone(), v.clone());
        }
        Params::deserialize(&Value::Object(given)).map_err(|e| bad("params", e))
    }

    /// The engine's options, validated, with a refused option as a 422
    /// naming it. `threads` and `max_output_faces` come from the service's
    /// configuration, not from the caller.
    pub fn job_options(
        &self,
        threads: usize,
        max_output_faces: u64,
    ) -> Result<RemeshOptions, Problem> {
        self.to_options(Some(threads.max(1)), max_output_faces)
            .map_err(|e| match e {
                RemeshError::InvalidOption { field, message } => bad(field, message),
                other => bad("params", other),
            })
    }
}

/// The first name that appears twice among the keys of a top-level JSON
/// object (`None` if none does, or if the value is not an object).
struct TopLevelKeys(Option<String>);

impl<'de> Deserialize<'de> for TopLevelKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Keys;
        impl<'de> serde::de::Visitor<'de> for Keys {
            type Value = TopLevelKeys;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON value")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<TopLevelKeys, A::Error> {
                let mut seen = std::collections::HashSet::new();
                let mut dup = None;
                while let Some(k) = map.next_key::<String>()? {
                    map.next_value::<serde::de::IgnoredAny>()?;
                    if !seen.insert(k.clone()) && dup.is_none() {
                        dup = Some(k);
                    }
                }
                Ok(TopLevelKeys(dup))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<TopLevelKeys, A::Error> {
                while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {}
                Ok(TopLevelKeys(None))
            }
            fn visit_bool<E>(self, _: bool) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
            fn visit_i64<E>(self, _: i64) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
            fn visit_u64<E>(self, _: u64) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
            fn visit_f64<E>(self, _: f64) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
            fn visit_str<E>(self, _: &str) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
            fn visit_unit<E>(self) -> Result<TopLevelKeys, E> {
                Ok(TopLevelKeys(None))
            }
        }
        d.deserialize_any(Keys)
    }
}

fn unknown(k: &str) -> Problem {
    bad(
        k,
        format!(
            "unknown parameter; the parameters are {}",
            PARAM_NAMES.join(", ")
        ),
    )
}

/// What the estimate needs to know about an input.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputGeometry {
    /// Surface area.
    pub area: f64,
    /// Bounding-box diagonal.
    pub bbox_diagonal: f64,
    /// Mean edge length of the repaired mesh.
    pub mean_edge_length: f64,
}

/// The pre-queue output estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The edge length the estimate uses: the resolved uniform target, or
    /// under adaptive sizing the smallest allowed target (an upper bound).
    pub edge_length: f64,
    /// area / (√3/4 · L²), saturated: for comparisons, never for messages.
    pub triangles: u64,
    /// area / (√3/4 · L²) unsaturated (infinite for a zero length): what a
    /// message quotes, through [`crate::remesh::face_count_text`].
    pub estimate: f64,
    /// The parameter that sets L, named in the 422 when the estimate is too large.
    pub field: &'static str,
}

/// Estimates the output triangle count as area / (√3/4 · L²).
///
/// Uniform sizing resolves L as the engine does (explicit length, ratio ×
/// diagonal, area from `target_faces`, or the mean edge length). Adaptive
/// sizing uses the smallest target the sizing field may assign:
/// `min_edge_length`, else the tolerance-derived minimum
/// (`DEFAULT_MIN_EDGE_FACTOR` × ε with ε = `tolerance`, or `tolerance_ratio`
/// (default 0.1 %) of the diagonal). That bounds the count from above, since flat regions get
/// longer edges; the engine re-checks with the real field before it allocates.
pub fn estimate_output(g: &InputGeometry, o: &RemeshOptions) -> Estimate {
    let (l, field) = match o.sizing {
        Sizing::Uniform => o.uniform_target(g.bbox_diagonal, g.area, || g.mean_edge_length),
        Sizing::Adaptive => (
            o.adaptive_sizing(g.bbox_diagonal).min_edge_length,
            if o.min_edge_length.is_some() {
                "min_edge_length"
            } else {
                "tolerance"
            },
        ),
    };
    let est = estimated_faces(g.area, l);
    let triangles = if est.is_finite() && est >= 0.0 {
        est.min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    };
    Estimate {
        edge_length: l,
        triangles,
        estimate: if est.is_nan() { f64::INFINITY } else { est },
        field,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::Format;
    use crate::sizing::DEFAULT_MIN_EDGE_FACTOR;

    #[test]
    fn query_values_take_their_types() {
        let q = |k: &str, v: &str| vec![(k.to_string(), v.to_string())];
        let p = Params::from_query(&q("iterations", "3")).unwrap();
        assert_eq!(p.iterations, 3);
        let p = Params::from_query(&q("sizing", "adaptive")).unwrap();
        assert_eq!(p.sizing, Sizing::Adaptive);
        let p = Params::from_query(&q("output_format", "STL")).unwrap();
        assert_eq!(p.output_format, Some(Format::Stl));
        let p = Params::from_query(&q("preserve_features", "false")).unwrap();
        assert!(!p.preserve_features);
    }

    #[test]
    fn every_problem_names_its_field() {
        let e = Params::from_json(&serde_json::json!({"iterations": "many"})).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("iterations"));
        let e = Params::from_json(&serde_json::json!({"threads": 4})).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("threads"));
        assert_eq!(e.status, 422);
        let e = Params::from_json(&serde_json::json!({"sizing": "fancy"})).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("sizing"));
        let e = Params::from_json(&serde_json::json!({"output_format": "fbx"})).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("output_format"));
        let p = Params::from_json(&serde_json::json!({"gradation": -1.0})).unwrap();
        let e = p.job_options(1, 100).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("gradation"));
        let dup = vec![
            ("iterations".into(), "1".into()),
            ("iterations".into(), "2".into()),
        ];
        assert_eq!(
            Params::from_query(&dup).unwrap_err().field.as_deref(),
            Some("iterations")
        );
    }

    #[test]
    fn a_repeated_name_in_the_params_json_is_refused_naming_it() {
        let e = Params::from_json_bytes(br#"{"iterations": 2, "gradation": 1, "iterations": 3}"#)
            .unwrap_err();
        assert_eq!((e.status, e.field.as_deref()), (422, Some("iterations")));
        assert!(e.detail.contains("more than once"), "{}", e.detail);
        let p = Params::from_json_bytes(br#"{"iterations": 2, "gradation": 1.5}"#).unwrap();
        assert_eq!(p.iterations, 2);
        // Not an object: the usual message, not a duplicate.
        let e = Params::from_json_bytes(b"[1, 1]").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("params"));
        let e = Params::from_json_bytes(b"{").unwrap_err();
        assert_eq!((e.status, e.field.as_deref()), (400, Some("params")));
    }

    #[test]
    fn estimate_follows_area_over_equilateral_triangle_area() {
        let g = InputGeometry {
            area: 6.0,
            bbox_diagonal: 3f64.sqrt(),
            mean_edge_length: 0.5,
        };
        let mut o = RemeshOptions::default().with_target_edge_length(0.1);
        let e = estimate_output(&g, &o);
        let expect = 6.0 / (3f64.sqrt() / 4.0 * 0.01);
        assert!((e.triangles as f64 - expect).abs() <= 1.0);
        assert_eq!(e.field, "target_edge_length");
        o = RemeshOptions::default().with_target_faces(1000);
        assert!((estimate_output(&g, &o).triangles as i64 - 1000).abs() <= 1);
        o = RemeshOptions {
            sizing: Sizing::Adaptive,
            tolerance: Some(0.01),
            ..Default::default()
        };
        let e = estimate_output(&g, &o);
        assert_eq!(e.field, "tolerance");
        assert!((e.edge_length - 0.01 * DEFAULT_MIN_EDGE_FACTOR).abs() < 1e-12);
        // A relative tolerance scales with the diagonal.
        o.tolerance = None;
        o.tolerance_ratio = Some(0.01);
        let e = estimate_output(&g, &o);
        assert!((e.edge_length - 0.01 * 3f64.sqrt() * DEFAULT_MIN_EDGE_FACTOR).abs() < 1e-12);
    }

    #[test]
    fn tolerance_ratio_is_a_parameter_and_excludes_tolerance() {
        let p =
            Params::from_json(&serde_json::json!({"sizing": "adaptive", "tolerance_ratio": 0.002}))
                .unwrap();
        assert_eq!(p.tolerance_ratio, Some(0.002));
        assert_eq!(
            p.job_options(1, 1 << 30).unwrap().tolerance_ratio,
            Some(0.002)
        );
        let both = Params::from_json(&serde_json::json!({
            "sizing": "adaptive", "tolerance": 0.01, "tolerance_ratio": 0.002
        }))
        .unwrap();
        assert_eq!(
            both.job_options(1, 1 << 30).unwrap_err().field.as_deref(),
            Some("tolerance")
        );
        let e = Params::from_json(&serde_json::json!({"tolerance_ratio": "x"})).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("tolerance_ratio"));
    }
}
