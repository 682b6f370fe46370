//! Shape metrics classify synthetic cells correctly; the renderer writes a
//! decodable PNG showing the mesh.

use glam::DVec3;
use remembrane::analysis::shape::{ShapeClass, shape_metrics};
use remembrane::mesh::{SurfaceMesh, icosphere_unit};

fn mapped(f: impl Fn(DVec3) -> DVec3) -> SurfaceMesh {
    let mut m = icosphere_unit(4);
    for p in &mut m.positions {
        *p = f(*p);
    }
    m
}

/// Evans–Fung red-blood-cell profile (µm): z = ±½ √(1 − ρ²)(C0 + C2 ρ² + C4 ρ⁴), ρ = r/R.
fn evans_fung(p: DVec3) -> DVec3 {
    let (r_cell, c0, c2, c4) = (3.91, 0.81, 7.83, -4.39);
    let rho2 = (p.x * p.x + p.y * p.y).min(1.0);
    let z = 0.5 * (1.0 - rho2).sqrt() * (c0 + c2 * rho2 + c4 * rho2 * rho2);
    DVec3::new(r_cell * p.x, r_cell * p.y, z * p.z.signum())
}

#[test]
fn classifies_sphere_ellipsoid_discocyte_and_cup() {
    let sphere = shape_metrics(&mapped(|p| 3.0 * p).positions, &mapped(|p| p).faces);
    assert_eq!(sphere.class, ShapeClass::Convex);
    assert!((sphere.diameter - 6.0).abs() < 0.05 && sphere.axisymmetry > 0.99);

    let oblate = mapped(|p| DVec3::new(4.0 * p.x, 4.0 * p.y, 1.5 * p.z));
    let m = shape_metrics(&oblate.positions, &oblate.faces);
    assert_eq!(m.class, ShapeClass::Convex);
    assert!(
        (m.max_height - 3.0).abs() < 0.05 && (m.diameter - 8.0).abs() < 0.05,
        "{m:?}"
    );
    assert!(m.axisymmetry > 0.99);

    let rbc = mapped(evans_fung);
    let m = shape_metrics(&rbc.positions, &rbc.faces);
    assert_eq!(m.class, ShapeClass::Discocyte, "{m:?}");
    assert!((m.diameter - 7.82).abs() < 0.1, "{m:?}");
    assert!(
        m.centre_to_max_height < 0.5 && m.axisymmetry > 0.99,
        "{m:?}"
    );

    // A cup: the lower face pushed up into the upper one.
    let cup = mapped(|p| {
        let rho2 = p.x * p.x + p.y * p.y;
        let z = if p.z < 0.0 {
            p.z + 1.2 * (1.0 - rho2)
        } else {
            p.z + 0.6 * (1.0 - rho2)
        };
        DVec3::new(3.0 * p.x, 3.0 * p.y, 2.0 * z)
    });
    let m = shape_metrics(&cup.positions, &cup.faces);
    assert_eq!(m.class, ShapeClass::Stomatocyte, "{m:?}");

    // Elongated along its symmetry axis: prolate, not a dimpled disc seen
    // side-on (the thinnest axis is then one of the two short ones).
    let prolate = mapped(|p| DVec3::new(3.0 * p.x, 3.0 * p.y, 4.5 * p.z));
    let m = shape_metrics(&prolate.positions, &prolate.faces);
    assert_eq!(m.class, ShapeClass::Prolate, "{m:?}");
    // Barely elongated (5 %): below the threshold, convex.
    let round = mapped(|p| DVec3::new(3.0 * p.x, 3.0 * p.y, 3.15 * p.z));
    assert_eq!(
        shape_metrics(&round.positions, &round.faces).class,
        ShapeClass::Convex
    );
}

#[test]
fn renders_a_decodable_png_with_the_mesh_in_both_views() {
    let rbc = mapped(evans_fung);
    let bytes = remembrane::io::render::render_png(&rbc.positions, &rbc.faces, 120);
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (240, 120));
    // Each panel has mesh pixels (not background) around its centre and
    // background in its corners.
    let pixel = |x: usize, y: usize| &buf[(y * 240 + x) * 3..(y * 240 + x) * 3 + 3];
    for panel in 0..2 {
        let cx = panel * 120 + 60;
        assert_ne!(
            pixel(cx, 60),
            [245, 245, 245],
            "panel {panel} centre is empty"
        );
        assert_eq!(pixel(panel * 120 + 2, 2), [245, 245, 245]);
    }
    // Side view of a flat cell: empty above and below the disc.
    assert_eq!(pixel(60, 10), [245, 245, 245]);
}

#[test]
fn a_field_colours_the_render_from_blue_to_red() {
    let rbc = mapped(evans_fung);
    // The field grows along the cell's widest axis: its two ends differ.
    let frame = remembrane::analysis::shape::principal_frame(&rbc.positions, &rbc.faces);
    let wide = frame.axes[2];
    let field: Vec<f64> = rbc.positions.iter().map(|p| p.dot(wide)).collect();
    let bytes =
        remembrane::io::render::render_png_coloured(&rbc.positions, &rbc.faces, Some(&field), 120);
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut buf).unwrap();
    // Along the top view's middle row, the reddest and the bluest mesh
    // pixels lie at opposite ends.
    let row: Vec<[u8; 3]> = (120..240)
        .map(|x| {
            let o = (60 * 240 + x) * 3;
            [buf[o], buf[o + 1], buf[o + 2]]
        })
        .filter(|p| *p != [245, 245, 245])
        .collect();
    let redness = |p: &[u8; 3]| f64::from(p[0]) - f64::from(p[2]);
    let (first, last) = (redness(&row[2]), redness(&row[row.len() - 3]));
    assert!(
        (first - last).abs() > 100.0,
        "{:?} … {:?}",
        row[2],
        row[row.len() - 3]
    );
}
