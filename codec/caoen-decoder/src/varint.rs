//! LEB128 numbers of at most 32 bits, in their shortest form: the container's lengths
//! and counts (see `docs/format.md`).

use super::CodecError;

/// Appends `v` as LEB128: 7 bits a byte, low bits first, the top bit set on every byte
/// but the last.
pub fn push(out: &mut Vec<u8>, v: u32) {
    leb128::write::unsigned(out, u64::from(v)).expect("writing to a Vec");
}

/// Bytes of `v` as LEB128.
pub fn len(v: u32) -> usize {
    (32 - v.leading_zeros()).max(1).div_ceil(7) as usize
}

/// The number at the start of `p` (which starts at byte `offset` of the file) and the
/// bytes it takes. One form per value: a number in more bytes than it needs, or past
/// 32 bits, is an error, as is `p` ending inside it.
pub fn read(p: &[u8], what: &'static str, offset: usize) -> Result<(u32, usize), CodecError> {
    // 32 bits take at most five bytes: the reader never looks further.
    let window = &p[..p.len().min(5)];
    let mut rest = window;
    let refused = CodecError::Varint {
        what,
        offset: offset as u64,
    };
    match leb128::read::unsigned(&mut rest) {
        Ok(v) => {
            let used = window.len() - rest.len();
            match u32::try_from(v) {
                Ok(v) if len(v) == used => Ok((v, used)),
                _ => Err(refused),
            }
        }
        Err(leb128::read::Error::IoError(_)) if window.len() < 5 => Err(CodecError::Truncated {
            what,
            offset: offset as u64,
            need: (p.len() + 1) as u64,
            available: p.len() as u64,
        }),
        Err(_) => Err(refused),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_in_their_shortest_form_only() {
        let edges = [
            0u32,
            1,
            127,
            128,
            16383,
            16384,
            (1 << 21) - 1,
            1 << 21,
            (1 << 28) - 1,
            1 << 28,
            u32::MAX,
        ];
        for v in edges {
            let mut b = Vec::new();
            push(&mut b, v);
            assert_eq!(b.len(), len(v), "{v}");
            // Trailing bytes are the next field's.
            b.push(0xAB);
            assert_eq!(read(&b, "v", 0).unwrap(), (v, len(v)), "{v}");
            // Every shorter prefix ran out.
            for cut in 0..len(v) {
                assert!(
                    matches!(read(&b[..cut], "v", 0), Err(CodecError::Truncated { .. })),
                    "{v} cut at {cut}"
                );
            }
        }
        // A value padded with a zero continuation byte, one past 32 bits, one that
        // never ends.
        for bad in [
            &[0x80, 0x00][..],
            &[0xFF, 0x80, 0x00][..],
            &[0x80, 0x80, 0x80, 0x80, 0x10][..],
            &[0xFF; 11][..],
        ] {
            let r = read(bad, "v", 7);
            assert!(
                matches!(
                    r,
                    Err(CodecError::Varint {
                        what: "v",
                        offset: 7
                    })
                ),
                "{bad:?}: {r:?}"
            );
        }
    }
}
