use caoen::{decode, encode, load, register_image_hooks, save, DecodeOptions, EncodeOptions};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).ok_or("usage: library-user DIR")?);
    let image = load(&dir.join("photo.png"))?;
    std::fs::write(dir.join("photo.cae"), encode(&image, &EncodeOptions::default())?)?;
    let decoded = decode(&std::fs::read(dir.join("photo.cae"))?, &DecodeOptions::default())?;
    save(&decoded, &dir.join("decoded.png"))?;
    register_image_hooks();
    image::open(dir.join("photo.cae"))?.save(dir.join("opened.png"))?;
    Ok(())
}
