//! The restoration section's payload: a byte whose bit `c` says colour plane `c` is
//! filtered, then each filtered plane's taps in [`shape`](super::shape)'s order, as
//! signed Exp-Golomb codes of order [`ORDER`] packed most significant bit first, the
//! last byte padded with zeros.

use super::{shape, Restoration, MAX_TAP};
use crate::codec::CodecError;

/// Exp-Golomb order of the taps' codes: most taps are a few units of `2^-8` either
/// side of zero, and order 2 gives those codes of 3 to 5 bits.
pub const ORDER: u32 = 2;

/// Bits of tap `v`'s code.
pub fn tap_bits(v: i32) -> u32 {
    let u = zigzag(v) + (1 << ORDER);
    let n = 31 - u.leading_zeros();
    2 * n + 1 - ORDER
}

/// Bits of a plane's taps.
pub fn tap_bits_all(taps: &[i32]) -> u32 {
    taps.iter().map(|&v| tap_bits(v)).sum()
}

/// Bits of a whole payload with the planes `planes`.
pub fn payload_bits(planes: &[Option<Vec<i32>>]) -> u32 {
    8 + planes
        .iter()
        .flatten()
        .map(|t| tap_bits_all(t))
        .sum::<u32>()
}

fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

fn unzigzag(u: u32) -> i32 {
    (u >> 1) as i32 ^ -((u & 1) as i32)
}

/// The payload of `r` (at most eight colour planes; taps within [`MAX_TAP`]).
pub fn write(r: &Restoration) -> Vec<u8> {
    let mask = r
        .planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_some())
        .fold(0u8, |m, (c, _)| m | 1 << c);
    let mut bits = BitWriter::default();
    for taps in r.planes.iter().flatten() {
        for &v in taps {
            debug_assert!(v.abs() <= MAX_TAP);
            let u = zigzag(v) + (1 << ORDER);
            let n = 31 - u.leading_zeros();
            bits.put(0, n - ORDER);
            bits.put(u, n + 1);
        }
    }
    let mut out = vec![mask];
    out.extend(bits.finish());
    out
}

/// Reads a payload for an image of `planes` colour planes.
pub fn parse(payload: &[u8], planes: usize) -> Result<Restoration, CodecError> {
    let bad = |reason: &'static str| CodecError::Restoration { reason };
    let (&mask, rest) = payload.split_first().ok_or(bad("the section is empty"))?;
    if mask == 0 {
        return Err(bad("no plane is filtered"));
    }
    if u32::from(mask) >> planes != 0 {
        return Err(bad("a filtered plane is past the image's colour planes"));
    }
    let mut bits = BitReader { bytes: rest, pos: 0 };
    let mut out = Vec::with_capacity(planes);
    for c in 0..planes {
        if mask >> c & 1 == 0 {
            out.push(None);
            continue;
        }
        let mut taps = Vec::with_capacity(shape(c).len());
        for _ in 0..shape(c).len() {
            let mut zeros = 0;
            while bits.get(1).ok_or(bad("the taps run past the section"))? == 0 {
                zeros += 1;
                // |tap| <= MAX_TAP needs at most 10 leading zeros.
                if zeros > 10 {
                    return Err(bad("a tap is out of range"));
                }
            }
            let n = zeros + ORDER;
            let low = bits.get(n).ok_or(bad("the taps run past the section"))?;
            let u = (1 << n | low) - (1 << ORDER);
            let v = unzigzag(u);
            if v.abs() > MAX_TAP {
                return Err(bad("a tap is out of range"));
            }
            taps.push(v);
        }
        out.push(Some(taps));
    }
    if bits.pos.div_ceil(8) != rest.len() || !bits.pos.is_multiple_of(8) && rest[bits.pos / 8] << (bits.pos % 8) != 0 {
        return Err(bad("bytes or bits follow the taps"));
    }
    Ok(Restoration { planes: out })
}

#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    acc: u64,
    n: u32,
}

impl BitWriter {
    /// Appends the low `n` bits of `v` (n <= 32), most significant first.
    fn put(&mut self, v: u32, n: u32) {
        for i in (0..n).rev() {
            self.acc = self.acc << 1 | u64::from(v >> i & 1);
            self.n += 1;
            if self.n == 8 {
                self.bytes.push(self.acc as u8);
                self.acc = 0;
                self.n = 0;
            }
        }
    }

    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.bytes.push((self.acc << (8 - self.n)) as u8);
        }
        self.bytes
    }
}

struct BitReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl BitReader<'_> {
    /// The next `n` bits (n <= 31), or `None` past the end.
    fn get(&mut self, n: u32) -> Option<u32> {
        let mut v = 0;
        for _ in 0..n {
            let byte = *self.bytes.get(self.pos / 8)?;
            v = v << 1 | u32::from(byte >> (7 - self.pos % 8) & 1);
            self.pos += 1;
        }
        Some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payloads_round_trip_and_their_bits_are_counted() {
        let cases = [
            Restoration {
                planes: vec![Some((0..12).map(|k| k * 97 % 2047 - MAX_TAP).collect()), None, Some(vec![0, 1, -1, 2, -2, MAX_TAP])],
            },
            Restoration {
                planes: vec![Some(vec![-MAX_TAP; 12])],
            },
            Restoration {
                planes: vec![None, Some(vec![3, -4, 5, -6, 7, 0]), None],
            },
        ];
        for r in cases {
            let bytes = write(&r);
            assert_eq!(parse(&bytes, r.planes.len()).unwrap(), r);
            assert_eq!(bytes.len() as u32, payload_bits(&r.planes).div_ceil(8));
        }
    }

    #[test]
    fn bad_payloads_are_errors() {
        let good = write(&Restoration {
            planes: vec![Some(vec![5; 12]), None, None],
        });
        // Truncated, extra byte, no plane, plane past the image, out-of-range tap.
        let mut long = good.clone();
        long.push(0);
        let cases: Vec<(Vec<u8>, usize)> = vec![
            (vec![], 3),
            (good[..good.len() - 1].to_vec(), 3),
            (long, 3),
            (vec![0], 3),
            (vec![2, 0xff], 1),
            ([vec![1], vec![0; 40]].concat(), 1),
        ];
        for (bytes, planes) in cases {
            assert!(
                matches!(parse(&bytes, planes), Err(CodecError::Restoration { .. })),
                "{bytes:?}"
            );
        }
    }
}
