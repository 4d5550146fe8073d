//! Anisotropic input: a torus tessellated with quads 2.65 times longer
//! around the tube than along the ring (the criterion bench's shape, at a
//! tenth of its size), remeshed at its mean edge length. Rows of short
//! ring edges between long tube edges used to survive every iteration as
//! needles, because merging the ends of a short edge put the merged vertex
//! more than 4/3·L from the far corners of its long neighbours. And a tube
//! of long, thin strips, as CAD tessellations make them.

use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::shapes;
use isoremesh::stats::{self, StatsOptions};

#[test]
fn an_anisotropic_torus_becomes_isotropic() {
    let input = shapes::torus(3.0, 1.0, 600, 75);
    let (mesh, _) = Mesh::from_trimesh(&input).unwrap();
    let out = remesh(&mesh, &RemeshOptions::default(), &mut NoObserver).unwrap();
    let l = out.report.target_edge_length;
    let res = out.mesh.to_trimesh();
    let s = stats::compute(
        &res,
        &StatsOptions {
            target_edge_length: Some(l),
            ..Default::default()
        },
    );
    let (angles, lengths) = (s.angles.unwrap(), s.edge_length.unwrap());
    // Before the very-short-edge stretch of the collapse guard: 7.8 % below
    // 30°, 95.6 % of the edges in the band, smallest angle 26.9°; with it
    // none below 30°, 99.9 % in the band, 35.1°.
    assert!(
        angles.below_30_fraction < 0.001,
        "{} of the triangles below 30°",
        angles.below_30_fraction
    );
    assert!(
        lengths.within_band > 0.99,
        "{} of the edges in the band",
        lengths.within_band
    );
    assert!(angles.min_deg > 25.0, "smallest angle {}°", angles.min_deg);
}

/// A CAD-style strip: a tube of radius 1 and length 36 tessellated as one
/// row of 48 quads, so every triangle is 36 long and 0.13 wide, as on the
/// rods of 2CylinderEngine. Splitting the long edges leaves a field of
/// needles. The collapse pass's shape guard compared each face with itself
/// before the collapse, and a collapse that removes the two worst faces
/// still narrows some neighbour a little, so it refused nearly every
/// collapse there: such a rod kept 16,000 faces, 60 % of them below 30°.
/// Comparing the one-ring's worst face before and after lets them go:
/// 462 faces, 0.4 % below 30°, 97 % of the edges in the band (17,591 faces
/// with the per-face test).
#[test]
fn a_strip_of_needles_becomes_isotropic() {
    let input = shapes::open_cylinder(1.0, 36.0, 48, 1);
    let (mesh, _) = Mesh::from_trimesh(&input).unwrap();
    // Without the curvature refinement, so the target is L everywhere and
    // the band measures the collapse pass alone.
    let options = RemeshOptions {
        target_edge_length: Some(1.0),
        refine_curved: false,
        ..RemeshOptions::default()
    };
    let out = remesh(&mesh, &options, &mut NoObserver).unwrap();
    let res = out.mesh.to_trimesh();
    let s = stats::compute(
        &res,
        &StatsOptions {
            target_edge_length: Some(1.0),
            ..Default::default()
        },
    );
    let (angles, lengths) = (s.angles.unwrap(), s.edge_length.unwrap());
    // An ideal mesh of this area (2π·36) at L = 1 has about 520 faces.
    let faces = res.triangles.len();
    assert!(faces < 800, "{faces} faces");
    assert!(
        angles.below_30_fraction < 0.01,
        "{} of the triangles below 30°",
        angles.below_30_fraction
    );
    assert!(
        lengths.within_band > 0.95,
        "{} of the edges in the band",
        lengths.within_band
    );
}
