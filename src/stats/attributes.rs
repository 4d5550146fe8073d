//! The `attributes` section of a job's statistics: which surface attributes
//! the input carried and the output keeps, and for each texture coordinate
//! set how well the remesh kept its seams, its charts' orientation, its
//! stretch and, when the base-colour texture can be decoded, the colour a
//! renderer shows.
//!
//! Definitions:
//! - a seam edge has two faces whose corners differ in the set at either
//!   end (positions welded first);
//! - seam fidelity samples every input seam edge (up to 8 points per edge,
//!   weighted by length) and measures the distance to the nearest output
//!   seam edge, in units of L;
//! - charts are the output's face components across non-seam edges; a
//!   triangle is UV-flipped when its UV orientation disagrees with the
//!   input's at its centroid (the input's closest face), which also holds
//!   for mirrored UV layouts where one chart has both orientations; it is
//!   UV-degenerate when its UV area is below 1e-12 (far below one texel of a
//!   16k texture);
//! - the L2 stretch is Sander, Snyder, Gortler & Hoppe (2001), the
//!   3D-area-weighted root mean square, scaled by √(UV area / 3D area) so
//!   that 1 is an isometry up to scale;
//! - the colour error samples the output's surface uniformly by area and
//!   compares, per channel in 8-bit units, the texel read (bilinear,
//!   repeating) through the output's UVs with the texel read through the
//!   input's UVs at the closest input point, on input faces of the output
//!   face's label, both through the label's `KHR_texture_transform` when
//!   its base-colour texture declares one.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::rng::Pcg64;
use crate::appearance::{Appearance, DroppedAttribute};
use crate::bvh::SegmentIndex;
use crate::topology::EdgeTable;
use crate::transfer::SourceAttributes;
use crate::trimesh::{weld_positions, TriMesh};

/// Samples of the texture colour error.
pub const COLOR_SAMPLES: usize = 100_000;

/// The largest texture decoded for the colour error, in pixels; larger
/// images are refused from their header, before decoding.
pub const MAX_TEXTURE_PIXELS: u64 = 64 * 1024 * 1024;

use crate::transfer::UV_DEGENERATE_AREA;

/// The attribute section of a job.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AttributeStats {
    /// The attributes of the input, by glTF name (`TEXCOORD_0`, `COLOR_0`).
    pub input: Vec<String>,
    /// The attributes of the output.
    pub output: Vec<String>,
    /// Attributes of the input that the output does not carry, with why.
    pub dropped: Vec<DroppedAttribute>,
    /// Where the output's normals come from: `recomputed` from the new
    /// surface, or `transferred` from the input's (`normals: "transfer"`).
    #[serde(default)]
    pub normals: String,
    /// One entry per texture coordinate set of the output.
    pub texcoords: Vec<TexcoordStats>,
    /// Things a reader should know about the figures (e.g. a texture that
    /// could not be decoded).
    pub notes: Vec<String>,
}

/// Figures of one texture coordinate set.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TexcoordStats {
    /// The set (`n` of `TEXCOORD_n`).
    pub set: u32,
    /// Seam edges of the input.
    pub seam_edges_in: u64,
    /// Seam edges of the output.
    pub seam_edges_out: u64,
    /// Total length of the input's seams, model units.
    pub seam_length_in: f64,
    /// Share of the input's seam length within 0.01·L of an output seam.
    pub seam_within_1pct_l: f64,
    /// Largest distance of an input seam sample from the output's seams, in L.
    pub seam_max_distance_l: f64,
    /// Charts of the output.
    pub charts_out: u64,
    /// Output triangles whose UV orientation disagrees with the input's at
    /// their centroid (their chart's majority without the input).
    pub uv_flipped: u64,
    /// Output triangles with (almost) no UV area.
    pub uv_degenerate: u64,
    /// Of `uv_degenerate`, the triangles over an input face that is itself
    /// UV-degenerate (the input maps that region to a point or a line), so
    /// that no placement of the output could give them UV area.
    #[serde(default)]
    pub uv_degenerate_inherited: u64,
    /// L2 texture stretch of the input.
    pub stretch_l2_in: f64,
    /// L2 texture stretch of the output.
    pub stretch_l2_out: f64,
    /// The texture colour error, when a base-colour texture uses this set
    /// and could be decoded.
    pub color_error: Option<ColorError>,
}

/// Per-channel colour differences between output and input, 8-bit units.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorError {
    /// Surface samples compared.
    pub samples: u64,
    /// Mean absolute difference per channel (R, G, B, A).
    pub mean: [f64; 4],
    /// 99th percentile of the absolute difference per channel.
    pub p99: [f64; 4],
}

/// The attribute section for `input` (as read) remeshed into `output` (as
/// written, vertices split per attribute value), with target length `l`.
pub fn compute(
    input: &TriMesh,
    source: Option<&SourceAttributes>,
    output: &TriMesh,
    l: f64,
) -> AttributeStats {
    let mut stats = AttributeStats {
        input: input.attributes.names(),
        output: output.attributes.names(),
        dropped: input.attributes.dropped.clone(),
        ..Default::default()
    };
    for name in &stats.input {
        if !stats.output.contains(name) && !stats.dropped.iter().any(|d| &d.name == name) {
            stats.dropped.push(DroppedAttribute {
                name: name.clone(),
                reason: "the output format has no place for it".into(),
            });
        }
    }
    let textures = Textures::new(input, &mut stats.notes);
    let sets = output
        .attributes
        .texcoords
        .len()
        .min(input.attributes.texcoords.len());
    // Each side is welded, and its edges paired, once for every set.
    let (welded_in, welded_out) = if sets > 0 {
        (Welded::new(input), Welded::new(output))
    } else {
        (Welded::default(), Welded::default())
    };
    for set in 0..sets {
        let (seams_in, len_in) = seam_segments(input, &welded_in, set);
        let (seams_out, _) = seam_segments(output, &welded_out, set);
        let (within, max_d) = seam_fidelity(&seams_in, &seams_out, l);
        let (charts, flipped, degenerate, inherited) =
            orientation(output, &welded_out, set, source);
        let color_error = source.and_then(|s| textures.error(input, s, output, set));
        stats.texcoords.push(TexcoordStats {
            set: set as u32,
            seam_edges_in: seams_in.len() as u64,
            seam_edges_out: seams_out.len() as u64,
            seam_length_in: len_in,
            seam_within_1pct_l: within,
            seam_max_distance_l: max_d,
            charts_out: charts,
            uv_flipped: flipped,
            uv_degenerate: degenerate,
            uv_degenerate_inherited: inherited,
            stretch_l2_in: stretch(input, set),
            stretch_l2_out: stretch(output, set),
            color_error,
        });
    }
    stats
}

/// A face over welded positions and its original corners.
type WeldedFace = ([u32; 3], [u32; 3]);

/// A mesh's faces over welded positions and their manifold edges'
/// half-edge pairs, built once per mesh for every texture coordinate set.
#[derive(Default)]
struct Welded {
    faces: Vec<WeldedFace>,
    /// Per welded face, its label.
    labels: Vec<u32>,
    twins: Vec<[u32; 2]>,
}

impl Welded {
    fn new(m: &TriMesh) -> Self {
        let (faces, labels) = welded_faces(m);
        let twins = twins(&faces);
        Self {
            faces,
            labels,
            twins,
        }
    }
}

/// Faces over welded positions, with their original corners: (welded
/// triangle, original triangle) for every face with three distinct welded
/// corners, and the label of each.
fn welded_faces(m: &TriMesh) -> (Vec<WeldedFace>, Vec<u32>) {
    let (weld, _) = weld_positions(&m.positions);
    m.triangles
        .iter()
        .enumerate()
        .filter_map(|(f, t)| {
            let w = t.map(|v| weld[v as usize]);
            (w[0] != w[1] && w[1] != w[2] && w[0] != w[2]).then_some(((w, *t), m.face_label(f)))
        })
        .unzip()
}

/// For each manifold edge of the welded faces `faces`: (face, corner k
/// running a→b, twin face, twin corner), i.e. half-edge pairs.
fn twins(faces: &[([u32; 3], [u32; 3])]) -> Vec<[u32; 2]> {
    let tris: Vec<[u32; 3]> = faces.iter().map(|(w, _)| *w).collect();
    let vertex_count = tris.iter().flatten().max().map_or(0, |&v| v as usize + 1);
    let mut out = Vec::new();
    EdgeTable::new(&tris, vertex_count).for_each(|_, _, run| {
        if let [(_, h0), (_, h1)] = *run {
            out.push([h0, h1]);
        }
    });
    out
}

/// Whether the twin half-edges `h` differ in set `set` at either end.
fn is_seam(m: &TriMesh, faces: &[([u32; 3], [u32; 3])], set: usize, [h0, h1]: [u32; 2]) -> bool {
    let uv = &m.attributes.texcoords[set];
    let at = |h: u32, w: u32| {
        let (wt, t) = faces[(h / 3) as usize];
        let k = (0..3).find(|&k| wt[k] == w).unwrap_or(0);
        uv[t[k] as usize].map(f32::to_bits)
    };
    let (wt, _) = faces[(h0 / 3) as usize];
    let (a, b) = (wt[(h0 % 3) as usize], wt[((h0 % 3 + 1) % 3) as usize]);
    at(h0, a) != at(h1, a) || at(h0, b) != at(h1, b)
}

/// The seam edges of set `set` as segments, and their total length.
fn seam_segments(m: &TriMesh, w: &Welded, set: usize) -> (Vec<[DVec3; 2]>, f64) {
    let faces = &w.faces;
    let segs: Vec<[DVec3; 2]> = w
        .twins
        .iter()
        .copied()
        .filter(|&h| is_seam(m, faces, set, h))
        .map(|[h0, _]| {
            let (_, t) = faces[(h0 / 3) as usize];
            let k = (h0 % 3) as usize;
            [
                m.positions[t[k] as usize],
                m.positions[t[(k + 1) % 3] as usize],
            ]
        })
        .collect();
    let len = segs.iter().map(|[a, b]| a.distance(*b)).sum();
    (segs, len)
}

/// (share of the input seam length within 0.01·L of an output seam,
/// largest distance in L).
fn seam_fidelity(seams_in: &[[DVec3; 2]], seams_out: &[[DVec3; 2]], l: f64) -> (f64, f64) {
    if seams_in.is_empty() {
        return (1.0, 0.0);
    }
    if seams_out.is_empty() || l <= 0.0 {
        return (0.0, f64::INFINITY);
    }
    let index = SegmentIndex::new(seams_out.len(), |s| seams_out[s]);
    // Collected in order and summed sequentially: a parallel reduction's
    // grouping varies with scheduling, and the figure must not.
    let per_segment: Vec<(f64, f64, f64)> = seams_in
        .par_iter()
        .map(|&[a, b]| {
            let len = a.distance(b);
            let k = ((len / (0.25 * l)).ceil() as usize).clamp(1, 8);
            let mut within = 0.0;
            let mut max_d = 0.0f64;
            for i in 0..=k {
                let p = a.lerp(b, i as f64 / k as f64);
                let d = index
                    .closest(p)
                    .map_or(f64::INFINITY, |s| s.distance_squared.sqrt());
                max_d = max_d.max(d / l);
                if i < k && d <= 0.01 * l {
                    within += len / k as f64;
                }
            }
            (within, len, max_d)
        })
        .collect();
    let (within, total, max_d) = per_segment.iter().fold((0.0, 0.0, 0.0f64), |x, y| {
        (x.0 + y.0, x.1 + y.1, x.2.max(y.2))
    });
    (if total > 0.0 { within / total } else { 1.0 }, max_d)
}

fn uv_area(uv: &[[f32; 2]], t: [u32; 3]) -> f64 {
    let p = t.map(|v| DVec2::new(f64::from(uv[v as usize][0]), f64::from(uv[v as usize][1])));
    0.5 * (p[1] - p[0]).perp_dot(p[2] - p[0])
}

/// (charts, UV-flipped triangles, UV-degenerate triangles, degenerate
/// ones over UV-degenerate input) of set `set`: flipped against the
/// input's orientation at the centroid when `source` is given, else
/// against the chart's majority (and then nothing counts as inherited).
fn orientation(
    m: &TriMesh,
    w: &Welded,
    set: usize,
    source: Option<&SourceAttributes>,
) -> (u64, u64, u64, u64) {
    let faces = &w.faces;
    let mut uf = crate::topology::UnionFind::new(faces.len());
    for &h in &w.twins {
        if !is_seam(m, faces, set, h) {
            uf.union(h[0] / 3, h[1] / 3);
        }
    }
    let roots = uf.into_roots();
    let uv = &m.attributes.texcoords[set];
    // Per chart: (positive, negative) triangle counts.
    let mut votes: HashMap<u32, (u64, u64)> = HashMap::new();
    let mut degenerate = 0;
    let areas: Vec<f64> = faces.iter().map(|&(_, t)| uv_area(uv, t)).collect();
    for (f, &a) in areas.iter().enumerate() {
        let v = votes.entry(roots[f]).or_default();
        if a.abs() < UV_DEGENERATE_AREA {
            degenerate += 1;
        } else if a > 0.0 {
            v.0 += 1;
        } else {
            v.1 += 1;
        }
    }
    // The input's signed UV area under the centroid of welded face `i`.
    let under = |src: &SourceAttributes, i: usize| {
        let q = m.corner_positions(&faces[i].1);
        let c = (q[0] + q[1] + q[2]) / 3.0;
        let n = (q[1] - q[0]).cross(q[2] - q[0]);
        src.uv_orientation_at(c, n, set, w.labels[i])
    };
    let inherited = source.map_or(0, |src| {
        (0..faces.len())
            .into_par_iter()
            .filter(|&i| {
                areas[i].abs() < UV_DEGENERATE_AREA
                    && under(src, i).is_some_and(|r| r.abs() < UV_DEGENERATE_AREA)
            })
            .count() as u64
    });
    let flipped = match source {
        Some(src) => faces
            .par_iter()
            .zip(&areas)
            .zip(&w.labels)
            .filter(|&((&(_, t), &a), &label)| {
                let q = m.corner_positions(&t);
                let c = (q[0] + q[1] + q[2]) / 3.0;
                let n = (q[1] - q[0]).cross(q[2] - q[0]);
                a.abs() >= UV_DEGENERATE_AREA
                    && src
                        .uv_orientation_at(c, n, set, label)
                        .is_some_and(|r| r.abs() >= UV_DEGENERATE_AREA && r * a < 0.0)
            })
            .count() as u64,
        None => votes.values().map(|&(p, n)| p.min(n)).sum(),
    };
    (votes.len() as u64, flipped, degenerate, inherited)
}

/// The normalised L2 stretch of set `set` over `m`'s faces.
fn stretch(m: &TriMesh, set: usize) -> f64 {
    let uv = &m.attributes.texcoords[set];
    let (mut num, mut area3, mut area_uv) = (0.0, 0.0, 0.0);
    for t in &m.triangles {
        let q = m.corner_positions(t);
        let [s, tt]: [[f64; 3]; 2] = [0, 1].map(|c| t.map(|v| f64::from(uv[v as usize][c])));
        let a = 0.5 * ((s[1] - s[0]) * (tt[2] - tt[0]) - (s[2] - s[0]) * (tt[1] - tt[0]));
        let a3 = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).length();
        if a.abs() < UV_DEGENERATE_AREA || a3 == 0.0 {
            continue;
        }
        let ss =
            (q[0] * (tt[1] - tt[2]) + q[1] * (tt[2] - tt[0]) + q[2] * (tt[0] - tt[1])) / (2.0 * a);
        let st = (q[0] * (s[2] - s[1]) + q[1] * (s[0] - s[2]) + q[2] * (s[1] - s[0])) / (2.0 * a);
        num += 0.5 * (ss.length_squared() + st.length_squared()) * a3;
        area3 += a3;
        area_uv += a.abs();
    }
    if area3 == 0.0 {
        return 0.0;
    }
    (num / area3).sqrt() * (area_uv / area3).sqrt()
}

/// A decoded texture, RGBA8.
struct Texture {
    width: u32,
    height: u32,
    rgba: Vec<u8>,
}

impl Texture {
    /// Bilinear, repeating, in [0, 255] per channel.
    fn sample(&self, uv: [f64; 2]) -> [f64; 4] {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let x = uv[0].rem_euclid(1.0) * w - 0.5;
        let y = uv[1].rem_euclid(1.0) * h - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |i: f64, j: f64| {
            let i = (i as i64).rem_euclid(i64::from(self.width)) as usize;
            let j = (j as i64).rem_euclid(i64::from(self.height)) as usize;
            let o = 4 * (j * self.width as usize + i);
            [0, 1, 2, 3].map(|c| f64::from(self.rgba[o + c]))
        };
        let (a, b, c, d) = (
            texel(x0, y0),
            texel(x0 + 1.0, y0),
            texel(x0, y0 + 1.0),
            texel(x0 + 1.0, y0 + 1.0),
        );
        [0, 1, 2, 3].map(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }
}

/// A `KHR_texture_transform` of a texture reference: texture coordinates
/// are scaled, rotated counter-clockwise about the origin and offset, in
/// that order, before the texture is read.
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvTransform {
    offset: [f64; 2],
    rotation: f64,
    scale: [f64; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self {
            offset: [0.0; 2],
            rotation: 0.0,
            scale: [1.0; 2],
        }
    }
}

impl UvTransform {
    /// The transform an extension object declares; a missing or malformed
    /// property keeps its default.
    fn parse(ext: &serde_json::Value) -> Self {
        let pair = |key: &str, default: [f64; 2]| {
            ext.get(key)
                .and_then(|v| v.as_array())
                .filter(|a| a.len() == 2)
                .and_then(|a| Some([a[0].as_f64()?, a[1].as_f64()?]))
                .filter(|p| p.iter().all(|x| x.is_finite()))
                .unwrap_or(default)
        };
        Self {
            offset: pair("offset", [0.0; 2]),
            rotation: ext
                .get("rotation")
                .and_then(|v| v.as_f64())
                .filter(|r| r.is_finite())
                .unwrap_or(0.0),
            scale: pair("scale", [1.0; 2]),
        }
    }

    /// The extension's matrix (translation × rotation × scale, with the
    /// rotation's columns (cos, sin) and (−sin, cos)) applied to `uv`.
    fn apply(&self, uv: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.rotation.sin_cos();
        let (x, y) = (uv[0] * self.scale[0], uv[1] * self.scale[1]);
        [
            self.offset[0] + c * x - s * y,
            self.offset[1] + s * x + c * y,
        ]
    }
}

/// The base-colour textures of a mesh's labels: per label, the texture
/// and the texture coordinate set it reads.
struct Textures {
    per_label: Vec<Option<(usize, u32, UvTransform)>>,
    decoded: Vec<Option<Texture>>,
}

impl Textures {
    fn new(m: &TriMesh, notes: &mut Vec<String>) -> Self {
        let look = m.appearance.as_deref();
        let empty = Appearance::default();
        let look = look.unwrap_or(&empty);
        let mut decoded: Vec<Option<Texture>> = Vec::new();
        let mut by_image: HashMap<usize, usize> = HashMap::new();
        let per_label = (0..m.label_count())
            .map(|l| {
                let raw = m.labels.get(l)?.material.as_ref()?.gltf.as_ref()?;
                let info = raw.get("pbrMetallicRoughness")?.get("baseColorTexture")?;
                let tex = info.get("index")?.as_u64()? as usize;
                let transform = info
                    .get("extensions")
                    .and_then(|e| e.get("KHR_texture_transform"));
                let set = transform
                    .and_then(|t| t.get("texCoord"))
                    .or_else(|| info.get("texCoord"))
                    .and_then(|v| v.as_u64())
                    .unwrap_or(0) as u32;
                let transform = transform.map_or_else(UvTransform::default, UvTransform::parse);
                let image = look.textures.get(tex)?.get("source")?.as_u64()? as usize;
                let slot = *by_image.entry(image).or_insert_with(|| {
                    decoded.push(decode(look, image, notes));
                    decoded.len() - 1
                });
                Some((slot, set, transform))
            })
            .collect();
        Self { per_label, decoded }
    }

    /// The base-colour texture of label `label` when it reads set `set`,
    /// with the label's texture transform.
    fn texture(&self, label: u32, set: usize) -> Option<(&Texture, UvTransform)> {
        let (slot, s, transform) = (*self.per_label.get(label as usize)?)?;
        let texture = (s as usize == set).then(|| self.decoded[slot].as_ref())??;
        Some((texture, transform))
    }

    /// The colour error of set `set`, when some label's base colour reads it.
    fn error(
        &self,
        input: &TriMesh,
        source: &SourceAttributes,
        output: &TriMesh,
        set: usize,
    ) -> Option<ColorError> {
        let out_uv = &output.attributes.texcoords[set];
        let faces: Vec<u32> = (0..output.triangles.len() as u32)
            .filter(|&f| self.texture(output.face_label(f as usize), set).is_some())
            .collect();
        if faces.is_empty() {
            return None;
        }
        let mut cumulative = Vec::with_capacity(faces.len());
        let mut total = 0.0;
        for &f in &faces {
            let q = output.corner_positions(&output.triangles[f as usize]);
            total += 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).length();
            cumulative.push(total);
        }
        let mut rng = Pcg64::from_seed(0x05ee_d0fc_0104);
        let draws: Vec<(u32, f64, f64)> = (0..COLOR_SAMPLES)
            .map(|_| {
                let x = rng.next_f64() * total;
                let i = cumulative.partition_point(|&c| c < x).min(faces.len() - 1);
                (faces[i], rng.next_f64(), rng.next_f64())
            })
            .collect();
        let diffs: Vec<[f64; 4]> = draws
            .par_iter()
            .filter_map(|&(f, r1, r2)| {
                let t = output.triangles[f as usize];
                let s = r1.sqrt();
                let bary = [1.0 - s, s * (1.0 - r2), s * r2];
                let q = output.corner_positions(&t);
                let p = q[0] * bary[0] + q[1] * bary[1] + q[2] * bary[2];
                let uv = [0, 1].map(|c| {
                    (0..3)
                        .map(|k| bary[k] * f64::from(out_uv[t[k] as usize][c]))
                        .sum::<f64>()
                });
                let (texture, transform) = self.texture(output.face_label(f as usize), set)?;
                let got = texture.sample(transform.apply(uv));
                let (face, uv_in) =
                    source.closest_texcoord(p, set, output.face_label(f as usize))?;
                let label = input.face_label(source.source_face(face) as usize);
                let (texture, transform) = self.texture(label, set)?;
                let want = texture.sample(transform.apply(uv_in));
                Some([0, 1, 2, 3].map(|c| (got[c] - want[c]).abs()))
            })
            .collect();
        if diffs.is_empty() {
            return None;
        }
        let n = diffs.len();
        let mut mean = [0.0; 4];
        let mut p99 = [0.0; 4];
        for c in 0..4 {
            let mut v: Vec<f64> = diffs.iter().map(|d| d[c]).collect();
            mean[c] = v.iter().sum::<f64>() / n as f64;
            v.sort_by(f64::total_cmp);
            p99[c] = v[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1];
        }
        Some(ColorError {
            samples: n as u64,
            mean,
            p99,
        })
    }
}

/// Decodes image `i` of `look` (PNG or JPEG), refusing images whose header
/// declares more than [`MAX_TEXTURE_PIXELS`]; a failure is noted, not fatal.
fn decode(look: &Appearance, i: usize, notes: &mut Vec<String>) -> Option<Texture> {
    let img = look.images.get(i)?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&img.bytes))
        .with_guessed_format()
        .ok()?;
    if reader.format().is_none() {
        notes.push(format!(
            "image {i} ({}) is not PNG or JPEG: its bytes are kept, the colour error is not measured",
            img.media_type().unwrap_or("unknown type")
        ));
        return None;
    }
    let header = image::ImageReader::new(std::io::Cursor::new(&img.bytes))
        .with_guessed_format()
        .ok()?
        .into_dimensions();
    match header {
        Ok((w, h)) if u64::from(w) * u64::from(h) > MAX_TEXTURE_PIXELS => {
            notes.push(format!(
                "image {i} declares {w}×{h} pixels, more than the {MAX_TEXTURE_PIXELS} decoded for the colour error"
            ));
            return None;
        }
        Err(e) => {
            notes.push(format!("image {i} cannot be read: {e}"));
            return None;
        }
        _ => {}
    }
    match reader.decode() {
        Ok(d) => {
            let rgba = d.to_rgba8();
            Some(Texture {
                width: rgba.width(),
                height: rgba.height(),
                rgba: rgba.into_raw(),
            })
        }
        Err(e) => {
            notes.push(format!("image {i} cannot be decoded: {e}"));
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::UvTransform;

    #[test]
    fn texture_transform_scales_rotates_then_offsets() {
        let ext = serde_json::json!({
            "offset": [0.5, 0.25],
            "rotation": std::f64::consts::FRAC_PI_2,
            "scale": [2.0, 3.0]
        });
        let t = UvTransform::parse(&ext);
        // (1, 1) → scaled (2, 3) → rotated a quarter turn (−3, 2) → offset.
        let [u, v] = t.apply([1.0, 1.0]);
        assert!(
            (u + 2.5).abs() < 1e-12 && (v - 2.25).abs() < 1e-12,
            "{u} {v}"
        );
        let bad = serde_json::json!({"offset": [1.0], "rotation": "x", "scale": [1.0, null]});
        assert_eq!(UvTransform::parse(&bad), UvTransform::default());
        assert_eq!(UvTransform::default().apply([0.3, 0.7]), [0.3, 0.7]);
    }
}
