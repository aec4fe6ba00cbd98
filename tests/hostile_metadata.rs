//! Metadata as cameras and editors damage it (`tests/bad/hostile/third-*`): a damaged
//! item never stops the work, an item an output cannot carry is left out of it, and
//! each is named in a warning when it would have been kept.

mod common;

use caoen::metadata::read_container;
use common::{caoen_ok, fresh_dir, hostile as bad, s, stderr};

#[test]
fn damaged_metadata_never_stops_an_encode() {
    let dir = fresh_dir("hostile-damaged-metadata");
    let out = dir.join("x.cae");
    // (input, the warning when the item would have been kept, the item's policy)
    for (input, warning, icc) in [
        (
            "third-D1-exif-not-tiff.jpg",
            "EXIF left out: EXIF does not start",
            false,
        ),
        (
            "third-D1c-icc-chunk-missing.jpg",
            "ICC profile left out: JPEG chunks",
            true,
        ),
        (
            "third-D1d-iccp-bad-zlib.png",
            "ICC profile left out: damaged zlib",
            true,
        ),
        (
            "third-D1e-png-exif-not-tiff.png",
            "EXIF left out: EXIF does not start",
            false,
        ),
    ] {
        let input = bad(input);
        for (policy, keeps) in [
            (&[][..], true),
            (&["--strip"][..], false),
            (&["--metadata", "icc"][..], icc),
            (&["--metadata", "none"][..], false),
        ] {
            let mut args = vec!["encode", &input, "-o", s(&out), "-f"];
            args.extend_from_slice(policy);
            let err = stderr(&caoen_ok(&args));
            assert_eq!(err.contains(warning), keeps, "{input} {policy:?}: {err}");
            assert_eq!(err.contains("warning:"), keeps, "{input} {policy:?}: {err}");
        }
    }
    // A doubled `Exif\0\0` prefix (a known writer bug) is repaired: the EXIF is kept.
    let err = stderr(&caoen_ok(&[
        "encode",
        &bad("third-D1b-exif-double-prefix.jpg"),
        "-o",
        s(&out),
        "-f",
    ]));
    assert!(!err.contains("warning:"), "{err}");
    let info = caoen_ok(&["info", s(&out), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert!(
        v.to_string().contains("EXIF") || v.to_string().contains("exif"),
        "{v}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn metadata_an_image_file_cannot_carry_is_left_out_with_a_warning() {
    let dir = fresh_dir("hostile-unfit-metadata");
    let at = |name: &str| dir.join(name).display().to_string();
    // (input, the warning, which item)
    for (input, warning, item) in [
        (
            "third-D5-exif-junk.cae",
            "EXIF left out: EXIF does not start",
            "exif",
        ),
        (
            "third-D6-cmyk-jpeg-cmyk-icc.jpg",
            "colour space is `CMYK`",
            "icc",
        ),
        (
            "third-M2-grey-jpeg-rgb-icc.jpg",
            "`RGB`, the pixels' is `GRAY`",
            "icc",
        ),
        (
            "third-M3-xmp-invalid-utf8.jpg",
            "XMP packet left out: not UTF-8",
            "xmp",
        ),
    ] {
        let cae = if input.ends_with(".cae") {
            bad(input)
        } else {
            // Kept in the `.cae` (caoen's own container holds any bytes) or left out
            // on the way in; either way not in the picture written from it.
            caoen_ok(&["encode", &bad(input), "-o", &at("in.cae"), "-f"]);
            at("in.cae")
        };
        let decoded = caoen_ok(&["decode", &cae, "-o", &at("out.png"), "-f"]);
        let encoded = stderr(&decoded);
        let png = std::fs::read(at("out.png")).unwrap();
        let meta = read_container(&png).unwrap();
        let present = match item {
            "icc" => meta.icc.is_some(),
            "exif" => meta.exif.is_some(),
            _ => meta.xmp.is_some(),
        };
        assert!(!present, "{input}: {meta:?}");
        // Named on the way in or on the way out.
        let encode_err = if input.ends_with(".cae") {
            String::new()
        } else {
            stderr(&caoen_ok(&[
                "encode",
                &bad(input),
                "-o",
                &at("in.cae"),
                "-f",
            ]))
        };
        assert!(
            encoded.contains(warning) || encode_err.contains(warning),
            "{input}: {encode_err}{encoded}"
        );
        // What caoen writes, caoen reads.
        caoen_ok(&["encode", &at("out.png"), "-o", &at("again.cae"), "-f"]);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pixels_turned_upright_say_so_in_exif_and_xmp() {
    let dir = fresh_dir("hostile-xmp-orientation");
    let cae = dir.join("m1.cae");
    let png = dir.join("m1.png");
    let input = bad("third-M1-exif-and-xmp-orientation-6.jpg");
    let before = read_container(&std::fs::read(&input).unwrap()).unwrap();
    let xmp = String::from_utf8(before.xmp.unwrap()).unwrap();
    assert!(xmp.contains(r#"tiff:Orientation="6""#), "{xmp}");
    caoen_ok(&["encode", &input, "-o", s(&cae)]);
    caoen_ok(&["decode", s(&cae), "-o", s(&png)]);
    let after = read_container(&std::fs::read(&png).unwrap()).unwrap();
    assert_eq!(
        caoen::metadata::orientation(after.exif.as_deref().unwrap()),
        Ok(Some(1))
    );
    let xmp = String::from_utf8(after.xmp.unwrap()).unwrap();
    assert!(xmp.contains(r#"tiff:Orientation="1""#), "{xmp}");
    assert!(
        xmp.contains("<dc:title>hostile4</dc:title>"),
        "the rest is kept: {xmp}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn every_command_sees_a_photo_upright() {
    let dir = fresh_dir("hostile-orientation-loader");
    let input = bad("third-M6-orientation-6.jpg");
    // Stored 96x64 with EXIF orientation 6: upright it is 64 wide and 96 tall.
    let stored = image::open(&input).unwrap();
    assert_eq!((stored.width(), stored.height()), (96, 64));
    // The shared loader (height maps, textures, patterns) turns it upright.
    let r = caoen::image_io::load(std::path::Path::new(&input)).unwrap();
    assert_eq!((r.width(), r.height()), (64, 96));
    let bytes = std::fs::read(&input).unwrap();
    let r = caoen::image_io::load_from_memory(&bytes, &Default::default()).unwrap();
    assert_eq!((r.width(), r.height()), (64, 96));
    // distort keeps the picture's size: the upright one.
    let png = dir.join("d.png");
    caoen_ok(&["distort", &input, "--move", "10,10:12,12", "-o", s(&png)]);
    let out = image::open(&png).unwrap();
    assert_eq!((out.width(), out.height()), (64, 96));
    // heightfield spans the picture's shape: narrower than tall.
    let model = dir.join("hf.json");
    caoen_ok(&["heightfield", &input, "-o", s(&model)]);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
    let rect = &v["model"]["intersection"][0]["height_map"]["rect"];
    let (w, h) = (
        rect[2].as_f64().unwrap() - rect[0].as_f64().unwrap(),
        rect[3].as_f64().unwrap() - rect[1].as_f64().unwrap(),
    );
    assert!((w / h - 64.0 / 96.0).abs() < 1e-9, "{rect}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_png_profile_whose_crc_is_wrong_is_left_out_and_the_pixels_encode() {
    let dir = fresh_dir("hostile-iccp-crc");
    let cae = dir.join("m4.cae");
    let input = bad("third-M4-iccp-bad-crc.png");
    let bytes = std::fs::read(&input).unwrap();
    // Read strictly, the damaged chunk is an error; leniently, a dropped item.
    assert!(read_container(&bytes).is_err());
    let (meta, dropped) = caoen::metadata::read_container_lenient(&bytes).unwrap();
    assert!(meta.icc.is_none());
    assert_eq!(dropped.len(), 1, "{dropped:?}");
    assert_eq!(dropped[0].item, caoen::metadata::Item::Icc);
    assert!(dropped[0].reason.contains("CRC is wrong"), "{dropped:?}");
    let err = stderr(&caoen_ok(&["encode", &input, "-o", s(&cae)]));
    assert!(
        err.contains("warning:") && err.contains("CRC is wrong"),
        "{err}"
    );
    let info = caoen_ok(&["info", s(&cae), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert!(v["metadata"]["icc"].is_null(), "{v}");
    // The pixels are all there.
    let png = dir.join("m4.png");
    caoen_ok(&["decode", s(&cae), "-o", s(&png)]);
    let (a, b) = (image::open(&input).unwrap(), image::open(&png).unwrap());
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn extended_xmp_is_joined_into_one_packet() {
    let dir = fresh_dir("hostile-xmp-extended");
    let (cae, png) = (dir.join("d7.cae"), dir.join("d7.png"));
    let input = bad("third-D7-xmp-extended.jpg");
    let err = stderr(&caoen_ok(&["encode", &input, "-o", s(&cae)]));
    assert!(!err.contains("warning:"), "{err}");
    caoen_ok(&["decode", s(&cae), "-o", s(&png)]);
    let xmp = read_container(&std::fs::read(&png).unwrap())
        .unwrap()
        .xmp
        .unwrap();
    let xmp = String::from_utf8(xmp).unwrap();
    // The depth map's properties travel in the extension, 120 KB over two segments.
    for property in [
        r#"GDepth:Format="RangeInverse""#,
        r#"GDepth:Near="0.5""#,
        r#"GDepth:Mime="image/png""#,
        "GDepth:Data=\"R1hkjoKRiTlKhS",
    ] {
        assert!(xmp.contains(property), "{property} missing");
    }
    assert!(xmp.len() > 120_000, "{} bytes", xmp.len());
    assert!(!xmp.contains("HasExtendedXMP"), "a pointer to nothing");
    assert_eq!(xmp.matches("<rdf:RDF").count(), 1, "one packet");
    // What caoen writes, caoen reads.
    let again = dir.join("again.cae");
    let err = stderr(&caoen_ok(&["encode", s(&png), "-o", s(&again)]));
    assert!(!err.contains("warning:"), "{err}");

    // One byte of the second chunk changed: its MD5 is no longer the GUID.
    let mut bytes = std::fs::read(&input).unwrap();
    let at = 65_500;
    assert!(bytes[at].is_ascii_alphanumeric());
    bytes[at] = if bytes[at] == b'A' { b'B' } else { b'A' };
    let damaged = dir.join("damaged.jpg");
    std::fs::write(&damaged, &bytes).unwrap();
    let err = stderr(&caoen_ok(&["encode", s(&damaged), "-o", s(&cae), "-f"]));
    assert!(
        err.contains("warning:") && err.contains("extended XMP left out") && err.contains("MD5"),
        "{err}"
    );
    caoen_ok(&["decode", s(&cae), "-o", s(&png), "-f"]);
    let xmp = read_container(&std::fs::read(&png).unwrap())
        .unwrap()
        .xmp
        .unwrap();
    let xmp = String::from_utf8(xmp).unwrap();
    assert!(
        !xmp.contains("HasExtendedXMP") && !xmp.contains("GDepth"),
        "{xmp}"
    );
    assert!(
        xmp.contains("rdf:Description"),
        "the main packet is kept: {xmp}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
