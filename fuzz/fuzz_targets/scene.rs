//! The scene reader on any text: an error or a scene, never a panic. Every mesh a scene names
//! is one triangle, so meshes cost nothing and the JSON is what is explored.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].map(Into::into);
        let _ = raycast::Scene::from_json(text, "fuzz.json".as_ref(), &mut |_, _| {
            Ok(vec![raycast::MeshPart {
                name: String::new(),
                triangles: vec![triangle],
            }])
        });
    }
});
