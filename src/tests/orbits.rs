//! An orbit's views see the scene's bounded objects (docs/datasets.md#orbits): on every course
//! scene, walls and all, each view of `--orbit 24` has its spheres and triangles on at least
//! 5% of its pixels; a flat scene is not looked at edge-on; walls that leave no room even for
//! the first view bring the eye nearer, with the image plane before the objects.

use super::common;

use raycast::scene::{Lens, Object, Orbit};
use raycast::{Cpu, Precision, RenderOptions, Scene};

/// The share of `scene`'s pixels whose id is a sphere or triangles, not a plane.
fn bounded_share(scene: &Scene) -> f64 {
    let options = RenderOptions {
        precision: Some(Precision::F32),
        ..RenderOptions::default()
    };
    let images = Cpu.render(scene, &options).unwrap();
    let id = images.id();
    let bounded = id
        .iter()
        .filter(|&&i| i >= 0 && !matches!(scene.objects[i as usize], Object::Plane { .. }))
        .count();
    bounded as f64 / id.len() as f64
}

/// Each view of `orbit` of `scene` at 64x36 pixels, with its share of bounded pixels.
fn shares(scene: &Scene, orbit: &Orbit) -> Vec<(String, f64)> {
    let cameras = orbit
        .names()
        .unwrap()
        .into_iter()
        .zip(orbit.cameras(scene).unwrap());
    cameras
        .map(|(name, mut camera)| {
            camera.resolution = [64, 36];
            let view = Scene {
                camera,
                ..scene.clone()
            };
            (name, bounded_share(&view))
        })
        .collect()
}

#[test]
fn every_view_of_an_orbit_sees_the_bounded_objects_of_every_course_scene() {
    let orbit = Orbit {
        views: 24,
        ..Orbit::default()
    };
    for path in common::scene_files("scenes/course") {
        let scene = Scene::load(&path).unwrap();
        for (name, share) in shares(&scene, &orbit) {
            assert!(
                share >= 0.05,
                "{}/{name}: bounded objects on {:.1}% of the pixels",
                path.display(),
                share * 100.0
            );
        }
    }
}

/// A box of walls closed on every side around the course bunny, the camera inside it: no
/// eye at the framing distance stays inside, so the orbit comes nearer, every view inside the
/// box and seeing the bunny, the course lens's image plane brought before it.
#[test]
fn a_closed_room_brings_the_eye_nearer_with_the_image_plane_before_the_objects() {
    let mut scene = common::course_scene("bunny");
    let plane = |point: [f64; 3], normal: [f64; 3]| Object::Plane {
        point: point.into(),
        normal: normal.into(),
    };
    scene.objects.push(plane([0.0, 0.0, 1.6], [0.0, 0.0, -1.0]));
    scene.camera.eye = [0.0, 0.0, 1.5].into();
    let views = Orbit {
        views: 8,
        ..Orbit::default()
    };
    let bunny = raycast::scene::bounds(&scene.objects[..1]).unwrap();
    let names = views.names().unwrap();
    for (name, camera) in names.into_iter().zip(views.cameras(&scene).unwrap()) {
        let e = camera.eye;
        let inside = e.x.abs() < 1.0 && e.y.abs() < 1.0 && e.z > -1.0 && e.z < 1.6;
        assert!(inside, "{name}: eye {} outside the room", camera.eye);
        let Lens::Size { width, height } = camera.lens else {
            panic!("{name}: the course lens is kept")
        };
        // The field of view stays the course camera's (1.7777777778 by 1 at focal length 1).
        let ratio = [width, height].map(|x| x / camera.focal_length);
        assert!((ratio[0] - 1.7777777778).abs() < 1e-9 && (ratio[1] - 1.0).abs() < 1e-9);
        // Rays start at the image plane: no corner of the bunny's box is nearer along the view.
        let ((lo, hi), forward) = (bunny, camera.look.normalize());
        for k in 0..8 {
            let pick = |bit: usize, a: f64, b: f64| if k & bit == 0 { a } else { b };
            let corner = glam::DVec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            );
            let depth = (corner - camera.eye).dot(forward);
            assert!(
                depth >= camera.focal_length - 1e-12,
                "{name}: a corner at {depth}"
            );
        }
    }
    for (name, share) in shares(&scene, &views) {
        assert!(share >= 0.05, "{name}: bunny on {share}");
    }
}
