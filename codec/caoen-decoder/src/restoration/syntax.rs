//! The restoration section's payload: a byte whose bit `c` (0 to 2) says colour plane
//! `c` is filtered, whose bit 7 says a colour map follows the filters and whose bit 6
//! says last luma filters follow the map, then each filtered plane in turn, the map
//! and the last filters (as a luma plane's), packed most significant bit first, the last byte padded
//! with zeros. A plane is a bit saying whether it is classified, then:
//!
//! - unclassified: its filter's taps;
//! - classified: the number of filters `n` less one (`1..=MAX_FILTERS`) as an
//!   Exp-Golomb code of order 0, then for each of the `CLASSES` pixel classes its
//!   filter (0 for none, else the filter's index plus one) in `width(n)` bits, the bits
//!   needed to write `n`, then the `n` filters' taps.
//!
//! Taps are in `shape`'s order, as signed Exp-Golomb codes of order
//! [`ORDER`]. The colour map is its rows in plane order, each row's coefficients and
//! then its offset, as signed Exp-Golomb codes of order
//! [`super::colour_map::MAP_ORDER`].

use super::colour_map::{ColourMap, MAP_ORDER, MAX_COEFFICIENT};
use super::{shape, PlaneFilter, Restoration, CLASSES, MAX_FILTERS, MAX_TAP};

/// The mask's bit saying a colour map follows the filters.
pub const COLOUR_MAP_BIT: u8 = 0x80;
/// The mask's bit saying the last luma filters follow the colour map.
pub const LAST_FILTER_BIT: u8 = 0x40;
use crate::CodecError;

/// Exp-Golomb order of the taps' codes: most taps are a few units of `2^-8` either
/// side of zero, and order 2 gives those codes of 3 to 5 bits.
pub const ORDER: u32 = 2;

/// Bits of tap `v`'s code.
pub fn tap_bits(v: i32) -> u32 {
    signed_bits(v, ORDER)
}

/// Bits of the signed Exp-Golomb code of order `k` of `v`.
pub fn signed_bits(v: i32, k: u32) -> u32 {
    let u = zigzag(v) + (1 << k);
    let n = 31 - u.leading_zeros();
    2 * n + 1 - k
}

/// Bits of a plane's taps.
pub fn tap_bits_all(taps: &[i32]) -> u32 {
    taps.iter().map(|&v| tap_bits(v)).sum()
}

/// Bits of a class's filter index in a plane of `n` filters.
pub fn index_width(n: usize) -> u32 {
    usize::BITS - n.leading_zeros()
}

/// Bits of the Exp-Golomb code of order 0 of `v`.
fn unsigned_bits(v: u32) -> u32 {
    2 * (31 - (v + 1).leading_zeros()) + 1
}

/// Bits of a plane with `n` filters classified, besides the taps.
pub fn classified_bits(n: usize) -> u32 {
    1 + unsigned_bits(n as u32 - 1) + CLASSES as u32 * index_width(n)
}

/// Bits of one plane's filters.
pub fn plane_bits(f: &PlaneFilter) -> u32 {
    let taps: u32 = f.filters.iter().map(|t| tap_bits_all(t)).sum();
    match f.classes {
        Some(_) => classified_bits(f.filters.len()) + taps,
        None => 1 + taps,
    }
}

/// Bits of a whole payload with the planes `planes` and no colour map.
pub fn payload_bits(planes: &[Option<PlaneFilter>]) -> u32 {
    8 + planes.iter().flatten().map(plane_bits).sum::<u32>()
}

fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

fn unzigzag(u: u32) -> i32 {
    (u >> 1) as i32 ^ -((u & 1) as i32)
}

/// The payload of `r` (at most three colour planes; taps within [`MAX_TAP`], a colour
/// map [`ColourMap::is_valid`]).
pub fn write(r: &Restoration) -> Vec<u8> {
    let mask = r
        .planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_some())
        .fold(0u8, |m, (c, _)| m | 1 << c)
        | if r.colour.is_some() {
            COLOUR_MAP_BIT
        } else {
            0
        }
        | if r.last.is_some() { LAST_FILTER_BIT } else { 0 };
    let mut bits = BitWriter::default();
    for f in r.planes.iter().flatten() {
        write_plane(&mut bits, f);
    }
    for &v in r.colour.iter().flat_map(|m| &m.rows).flatten() {
        debug_assert!(v.abs() <= MAX_COEFFICIENT);
        bits.exp_golomb(zigzag(v), MAP_ORDER);
    }
    if let Some(f) = &r.last {
        write_plane(&mut bits, f);
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
        return Err(bad(
            "no plane is filtered and no colour map or last filter follows",
        ));
    }
    if u32::from(mask & !(COLOUR_MAP_BIT | LAST_FILTER_BIT)) >> planes != 0 {
        return Err(bad("a filtered plane is past the image's colour planes"));
    }
    let mut bits = BitReader {
        bytes: rest,
        pos: 0,
    };
    let mut out = Vec::with_capacity(planes);
    for c in 0..planes {
        if mask >> c & 1 == 0 {
            out.push(None);
            continue;
        }
        out.push(Some(parse_plane(&mut bits, c)?));
    }
    let colour = if mask & COLOUR_MAP_BIT != 0 {
        let mut rows = Vec::with_capacity(planes);
        for _ in 0..planes {
            let mut row = Vec::with_capacity(planes + 1);
            for _ in 0..=planes {
                // |v| <= MAX_COEFFICIENT needs at most 12 leading zeros.
                let v = unzigzag(bits.exp_golomb(MAP_ORDER, 12).ok_or(bad(
                    "a colour map coefficient is out of range or past the section",
                ))?);
                if v.abs() > MAX_COEFFICIENT {
                    return Err(bad("a colour map coefficient is out of range"));
                }
                row.push(v);
            }
            rows.push(row);
        }
        Some(ColourMap { rows })
    } else {
        None
    };
    let last = if mask & LAST_FILTER_BIT != 0 {
        Some(parse_plane(&mut bits, 0)?)
    } else {
        None
    };
    if bits.pos.div_ceil(8) != rest.len()
        || !bits.pos.is_multiple_of(8) && rest[bits.pos / 8] << (bits.pos % 8) != 0
    {
        return Err(bad("bytes or bits follow the taps"));
    }
    Ok(Restoration {
        planes: out,
        colour,
        last,
    })
}

/// Appends one plane's filters.
fn write_plane(bits: &mut BitWriter, f: &PlaneFilter) {
    debug_assert!((1..=MAX_FILTERS).contains(&f.filters.len()));
    bits.put(u32::from(f.classes.is_some()), 1);
    if let Some(map) = &f.classes {
        let n = f.filters.len();
        bits.exp_golomb(n as u32 - 1, 0);
        for &m in map {
            debug_assert!(usize::from(m) <= n);
            bits.put(u32::from(m), index_width(n));
        }
    }
    for taps in &f.filters {
        for &v in taps {
            debug_assert!(v.abs() <= MAX_TAP);
            bits.exp_golomb(zigzag(v), ORDER);
        }
    }
}

/// Reads one plane's filters (colour plane `c`'s shape).
fn parse_plane(bits: &mut BitReader, c: usize) -> Result<PlaneFilter, CodecError> {
    let bad = |reason: &'static str| CodecError::Restoration { reason };
    let past = || bad("the filters run past the section");
    let classified = bits.get(1).ok_or_else(past)? == 1;
    let (n, classes) = if classified {
        // n <= MAX_FILTERS needs at most 4 leading zeros.
        let n = bits
            .exp_golomb(0, 4)
            .ok_or(bad("a plane's filter count is out of range"))? as usize
            + 1;
        if n > MAX_FILTERS {
            return Err(bad("a plane's filter count is out of range"));
        }
        let mut map = [0u8; CLASSES];
        for m in map.iter_mut() {
            let v = bits.get(index_width(n)).ok_or_else(past)? as usize;
            if v > n {
                return Err(bad("a class's filter is past the plane's filters"));
            }
            *m = v as u8;
        }
        (n, Some(map))
    } else {
        (1, None)
    };
    let mut filters = Vec::with_capacity(n);
    for _ in 0..n {
        let mut taps = Vec::with_capacity(shape(c).len());
        for _ in 0..shape(c).len() {
            // |tap| <= MAX_TAP needs at most 10 leading zeros.
            let v = unzigzag(
                bits.exp_golomb(ORDER, 10)
                    .ok_or(bad("a tap is out of range or past the section"))?,
            );
            if v.abs() > MAX_TAP {
                return Err(bad("a tap is out of range"));
            }
            taps.push(v);
        }
        filters.push(taps);
    }
    Ok(PlaneFilter { filters, classes })
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

    /// Appends `u`'s Exp-Golomb code of order `k`.
    fn exp_golomb(&mut self, u: u32, k: u32) {
        let u = u + (1 << k);
        let n = 31 - u.leading_zeros();
        self.put(0, n - k);
        self.put(u, n + 1);
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

    /// The next Exp-Golomb code of order `k` with at most `max_zeros` leading zeros,
    /// or `None` past the end or past that many zeros.
    fn exp_golomb(&mut self, k: u32, max_zeros: u32) -> Option<u32> {
        let mut zeros = 0;
        while self.get(1)? == 0 {
            zeros += 1;
            if zeros > max_zeros {
                return None;
            }
        }
        let n = zeros + k;
        let low = self.get(n)?;
        Some((1 << n | low) - (1 << k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payloads_round_trip_and_their_bits_are_counted() {
        let cases = [
            Restoration {
                planes: vec![
                    Some(PlaneFilter::single(
                        (0..12).map(|k| k * 97 % 2047 - MAX_TAP).collect(),
                    )),
                    None,
                    Some(PlaneFilter::single(vec![0, 1, -1, 2, -2, MAX_TAP])),
                ],
                colour: None,
                last: None,
            },
            // One plane with a gain and offset at the ends of their range.
            Restoration {
                planes: vec![Some(PlaneFilter::single(vec![-MAX_TAP; 12]))],
                colour: Some(ColourMap {
                    rows: vec![vec![MAX_COEFFICIENT, -MAX_COEFFICIENT]],
                }),
                last: Some(PlaneFilter::single(vec![
                    MAX_TAP, -MAX_TAP, 0, 1, -1, 2, -2, 3, 30, -30, 300, -300,
                ])),
            },
            Restoration {
                planes: vec![
                    None,
                    Some(PlaneFilter::single(vec![3, -4, 5, -6, 7, 0])),
                    None,
                ],
                colour: Some(ColourMap {
                    rows: vec![vec![0, 1, -2, 3], vec![-40, 0, 0, 7], vec![25, -13, 0, 0]],
                }),
                last: None,
            },
            // A colour map alone.
            Restoration {
                planes: vec![None, None, None],
                colour: Some(ColourMap {
                    rows: vec![vec![1, 0, 0, 0], vec![0; 4], vec![0, 0, -1, 100]],
                }),
                last: None,
            },
            // A last filter alone.
            Restoration {
                planes: vec![None, None, None],
                colour: None,
                last: Some(PlaneFilter {
                    filters: vec![vec![-5, 12, 3, 0, 0, 7, -1, 2, 2, 0, 9, -4], vec![1; 12]],
                    classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
                }),
            },
            // Classified planes of one filter, of the most, and chroma classified too.
            Restoration {
                planes: vec![
                    Some(PlaneFilter {
                        filters: vec![vec![7; 12]],
                        classes: Some(std::array::from_fn(|k| (k % 2) as u8)),
                    }),
                    Some(PlaneFilter {
                        filters: (0..MAX_FILTERS as i32)
                            .map(|f| (0..6).map(|k| f * 11 - k * 5).collect())
                            .collect(),
                        classes: Some(std::array::from_fn(|k| (k % (MAX_FILTERS + 1)) as u8)),
                    }),
                    None,
                ],
                colour: None,
                last: None,
            },
        ];
        for r in cases {
            let bytes = write(&r);
            assert_eq!(parse(&bytes, r.planes.len()).unwrap(), r);
            let map = r
                .colour
                .as_ref()
                .map_or(0, super::super::colour_map::map_bits);
            let last = r.last.as_ref().map_or(0, plane_bits);
            assert_eq!(
                bytes.len() as u32,
                (payload_bits(&r.planes) + map + last).div_ceil(8)
            );
        }
    }

    #[test]
    fn bad_payloads_are_errors() {
        let good = write(&Restoration {
            planes: vec![Some(PlaneFilter::single(vec![5; 12])), None, None],
            colour: None,
            last: None,
        });
        // A grey image's colour map, whose offset is out of range.
        let far_map = {
            let mut bits = BitWriter::default();
            bits.exp_golomb(0, MAP_ORDER);
            bits.exp_golomb(zigzag(MAX_COEFFICIENT + 1), MAP_ORDER);
            [vec![COLOUR_MAP_BIT], bits.finish()].concat()
        };
        // A classified plane of two filters: an index past them, and a count past
        // the most, must be errors.
        let classified = |map_first: u8, n: usize| {
            let mut bits = BitWriter::default();
            bits.put(1, 1);
            bits.exp_golomb(n as u32 - 1, 0);
            for k in 0..CLASSES {
                bits.put(
                    if k == 0 { u32::from(map_first) } else { 1 },
                    index_width(n),
                );
            }
            for _ in 0..n * 12 {
                bits.exp_golomb(0, ORDER);
            }
            [vec![1u8], bits.finish()].concat()
        };
        assert!(parse(&classified(2, 2), 1).is_ok());
        // Truncated, extra byte, no plane, plane past the image, out-of-range tap,
        // a class's filter past the plane's, too many filters, a colour map cut short
        // and one out of range.
        let mut long = good.clone();
        long.push(0);
        let cases: Vec<(Vec<u8>, usize)> = vec![
            (vec![], 3),
            (good[..good.len() - 1].to_vec(), 3),
            (long, 3),
            (vec![0], 3),
            (vec![2, 0xff], 1),
            ([vec![1], vec![0; 40]].concat(), 1),
            (classified(3, 2), 1),
            (classified(0, MAX_FILTERS + 1), 1),
            (vec![COLOUR_MAP_BIT, 0x80], 3),
            (vec![LAST_FILTER_BIT, 0x80], 3),
            (vec![0x20], 3),
            (far_map, 1),
        ];
        for (bytes, planes) in cases {
            assert!(
                matches!(parse(&bytes, planes), Err(CodecError::Restoration { .. })),
                "{bytes:?}"
            );
        }
    }
}
