//! A ZIP archive writer for the few parts of a 3MF package: each entry deflated
//! (miniz_oxide, pure Rust) or stored when that is no larger, no ZIP64 (an entry or the
//! archive over 4 GiB is refused), and a fixed timestamp, so the same parts give the
//! same bytes.

use std::io;

/// 1980-01-01 00:00 in MS-DOS form (date, time): reproducible archives.
const DOS_DATE: u16 = (1 << 5) | 1;
const DOS_TIME: u16 = 0;

/// `v` as a ZIP 32-bit field, or an error naming what overflowed.
fn u32_of(v: usize, what: &str) -> io::Result<u32> {
    u32::try_from(v).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{what} over 4 GiB: too large for a ZIP archive without ZIP64"),
        )
    })
}

/// The ZIP archive of `entries` (name, contents), in order.
pub fn zip(entries: &[(&str, &[u8])]) -> io::Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, data) in entries {
        let crc = crc32fast::hash(data);
        let deflated = miniz_oxide::deflate::compress_to_vec(data, 6);
        let (method, body): (u16, &[u8]) = if deflated.len() < data.len() {
            (8, &deflated)
        } else {
            (0, data)
        };
        let offset = u32_of(out.len(), "the archive")?;
        let fields = |sig: u32, central: bool| -> io::Result<Vec<u8>> {
            let mut h = Vec::new();
            h.extend_from_slice(&sig.to_le_bytes());
            if central {
                h.extend_from_slice(&20u16.to_le_bytes()); // made by: ZIP 2.0
            }
            h.extend_from_slice(&20u16.to_le_bytes()); // needed to extract: 2.0
            h.extend_from_slice(&0u16.to_le_bytes()); // flags
            h.extend_from_slice(&method.to_le_bytes());
            h.extend_from_slice(&DOS_TIME.to_le_bytes());
            h.extend_from_slice(&DOS_DATE.to_le_bytes());
            h.extend_from_slice(&crc.to_le_bytes());
            h.extend_from_slice(&u32_of(body.len(), name)?.to_le_bytes());
            h.extend_from_slice(&u32_of(data.len(), name)?.to_le_bytes());
            h.extend_from_slice(&(name.len() as u16).to_le_bytes());
            h.extend_from_slice(&0u16.to_le_bytes()); // extra field length
            if central {
                // Comment length, disk, internal and external attributes, offset.
                h.extend_from_slice(&[0; 10]);
                h.extend_from_slice(&offset.to_le_bytes());
            }
            h.extend_from_slice(name.as_bytes());
            Ok(h)
        };
        out.extend(fields(0x0403_4b50, false)?);
        out.extend_from_slice(body);
        central.extend(fields(0x0201_4b50, true)?);
    }
    let start = u32_of(out.len(), "the archive")?;
    let size = u32_of(central.len(), "the central directory")?;
    out.extend(central);
    let n = entries.len() as u16;
    out.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    out.extend_from_slice(&[0; 4]); // this disk, the directory's disk
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&size.to_le_bytes());
    out.extend_from_slice(&start.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes()); // comment length
    Ok(out)
}
