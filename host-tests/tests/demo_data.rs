//! The synthetic image pairs bundled with the tool (`cli/data/images`, see
//! its README) are what the scene generator makes from `truth.json`, byte
//! for byte. `REGENERATE_DEMO_DATA=1 cargo test -p host-tests --test
//! demo_data` rewrites them instead of checking.

use std::path::{Path, PathBuf};

use host_tests::reference::Image;
use host_tests::scene::{self, Damage, PbmFormat, Scene, Transform};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Side of the bundled images.
const SIZE: usize = 128;

fn images_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../cli/data/images")
}

/// The scene, damage and render seed of each bundled pair, by name.
fn scene_of(name: &str) -> (Scene, Damage, u64) {
    let rng = |seed| ChaCha8Rng::seed_from_u64(seed);
    match name {
        "polygon" => (scene::random_polygon(&mut rng(11)), Damage::MODERATE, 101),
        "room" => (scene::manhattan_room(&mut rng(12)), Damage::MODERATE, 102),
        "l-shape" => (scene::l_shape(1.6, 0.9), Damage::CLEAN, 103),
        "corridor" => (scene::corridor(&mut rng(14)), Damage::MODERATE, 104),
        other => panic!("truth.json names an unknown pair {other}"),
    }
}

/// The bytes of a bundled image file: P4 PBM for `.pbm` (P1 for the room, to
/// bundle both encodings), PNG for `.png` (black = occupied).
fn encode(image: &Image, file: &str) -> Vec<u8> {
    if file.ends_with(".png") {
        let grey = image::GrayImage::from_fn(image.width as u32, image.height as u32, |c, r| {
            image::Luma([if image.get(c as usize, r as usize) {
                0
            } else {
                255
            }])
        });
        let mut bytes = Vec::new();
        grey.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
        bytes
    } else if file.contains("room") {
        scene::to_pbm(image, PbmFormat::Ascii)
    } else {
        scene::to_pbm(image, PbmFormat::Binary)
    }
}

#[test]
fn bundled_images_match_the_generator() {
    let dir = images_dir();
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("truth.json")).unwrap()).unwrap();
    let regenerate = std::env::var_os("REGENERATE_DEMO_DATA").is_some();
    let pairs = manifest.as_array().unwrap();
    assert_eq!(pairs.len(), 4);
    for spec in pairs {
        let name = spec["name"].as_str().unwrap();
        let number = |key: &str| spec[key].as_f64().unwrap();
        let (scene, damage, seed) = scene_of(name);
        let transform = Transform {
            alpha_rad: number("alpha_deg").to_radians(),
            tx: number("tx_px"),
            ty: number("ty_px"),
            scale: 1.0,
        };
        let pair = scene::render_pair(&scene, &transform, &damage, SIZE, SIZE, seed);
        for (key, image) in [("a", &pair.i1.image), ("b", &pair.i2.image)] {
            // Names relative to cli/data, e.g. "images/polygon-a.pbm".
            let file = spec[key].as_str().unwrap();
            let path = dir.join("..").join(file);
            let made = encode(image, file);
            if regenerate {
                std::fs::write(&path, made).unwrap();
            } else {
                assert!(
                    std::fs::read(&path).unwrap() == made,
                    "{file} differs from the generator: run \
                     `REGENERATE_DEMO_DATA=1 cargo test -p host-tests --test demo_data`"
                );
            }
        }
    }
}
