//! `caoen decode --region`: a rectangle of the image at any size, equal to the same
//! rectangle of a whole decode at that scale; bad regions are usage errors.

mod common;
use common::{caoen, caoen_ok, s, stderr};

#[test]
fn a_region_is_the_crop_of_the_whole_decode_at_its_scale() {
    let dir = common::fresh_dir("cli-region");
    let png = dir.join("scene.png");
    caoen_corpus::generate(caoen_corpus::Class::Scene, 96, 64, 5)
        .to_dynamic_image()
        .save(&png)
        .unwrap();
    let cae = dir.join("scene.cae");
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "-q", "70", "--quiet"]);
    let whole = dir.join("whole.png");
    caoen_ok(&[
        "decode",
        s(&cae),
        "--size",
        "192x128",
        "-o",
        s(&whole),
        "--quiet",
    ]);
    let part = dir.join("part.png");
    caoen_ok(&[
        "decode",
        s(&cae),
        "--region",
        "20,8,52,40",
        "--size",
        "64x64",
        "-o",
        s(&part),
        "--quiet",
    ]);
    let whole = image::open(&whole).unwrap().to_rgb8();
    let part = image::open(&part).unwrap().to_rgb8();
    assert_eq!(part.dimensions(), (64, 64));
    let crop = image::imageops::crop_imm(&whole, 40, 16, 64, 64).to_image();
    assert_eq!(part, crop);
    // --scale scales the region's own size; without either, the region's own size.
    let scaled = dir.join("scaled.png");
    caoen_ok(&[
        "decode",
        s(&cae),
        "--region",
        "20,8,52,40",
        "--scale",
        "2",
        "-o",
        s(&scaled),
        "--quiet",
    ]);
    assert_eq!(image::open(&scaled).unwrap().to_rgb8(), part);
    let own = dir.join("own.png");
    caoen_ok(&[
        "decode",
        s(&cae),
        "--region",
        "0.5,0.5,10.25,8",
        "-o",
        s(&own),
        "--quiet",
    ]);
    assert_eq!(image::image_dimensions(&own).unwrap(), (10, 8));
    // Bad regions: usage errors naming the values, no output.
    for (region, says) in [
        ("1,2,3", "four numbers"),
        ("a,0,1,1", "x0,y0,x1,y1"),
        ("10,0,5,5", "x0 < x1"),
        ("0,0,97,10", "within the image"),
        ("-1,0,5,5", "within the image"),
        ("nan,0,5,5", "finite"),
    ] {
        let bad = dir.join("bad.png");
        let out = caoen(&["decode", s(&cae), "--region", region, "-o", s(&bad)]);
        assert_eq!(out.status.code(), Some(2), "{region}: {}", stderr(&out));
        assert!(stderr(&out).contains(says), "{region}: {}", stderr(&out));
        assert!(!bad.exists());
    }
}
