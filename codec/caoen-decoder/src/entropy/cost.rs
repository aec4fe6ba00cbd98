//! Back ends that price symbols without writing them: the encoder's rate estimates.

use super::coder::SymbolSink;
use super::model::{BinModel, Cdf};

/// Counts the cost of symbols (1/256 bits) without writing: the encoder's rate estimate.
#[derive(Debug, Default, Clone)]
pub struct CostSink {
    /// Accumulated cost in 1/256 bits.
    pub cost: u64,
}

impl SymbolSink for CostSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        self.cost += m.cost(bit) as u64;
        m.update(bit);
    }

    #[inline]
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize) {
        self.cost += m.cost(s) as u64;
        m.update(s);
    }

    #[inline]
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool) {
        self.cost += m.signed_cost(t, negative) as u64;
        m.update(t);
    }

    #[inline]
    fn raw(&mut self, _v: u32, bits: u32) {
        self.cost += 256 * bits as u64;
    }
}

/// A [`CostSink`] that leaves the models it is handed untouched: their adapted states
/// live in a small overlay keyed by the model's address, so pricing a candidate needs
/// no copy of every context, only of those it touches. Costs equal [`CostSink`]'s on a
/// copy of the models.
#[derive(Debug, Default, Clone)]
pub struct OverlayCostSink {
    /// Accumulated cost in 1/256 bits.
    pub cost: u64,
    bins: Vec<(usize, BinModel)>,
    /// Address, entries (the first `W` of them used) and count seen.
    cdfs: Vec<(usize, [u64; OVERLAY_W], u16)>,
}

/// Widest [`Cdf`] the overlay holds.
const OVERLAY_W: usize = 8;

impl OverlayCostSink {
    /// Forgets the cost and every adapted state, for the next candidate.
    pub fn reset(&mut self) {
        self.cost = 0;
        self.bins.clear();
        self.cdfs.clear();
    }

    /// Prices `s` on the overlay's state of `m` and adapts that state.
    #[inline]
    fn price<const W: usize>(&mut self, m: &Cdf<W>, s: usize, cost: impl Fn(&Cdf<W>) -> u32) {
        const { assert!(W <= OVERLAY_W) };
        let key = m as *const Cdf<W> as usize;
        match self.cdfs.iter_mut().find(|e| e.0 == key) {
            Some(e) => {
                let mut local = Cdf::<W> {
                    w: std::array::from_fn(|i| e.1[i]),
                    seen: e.2,
                };
                self.cost += cost(&local) as u64;
                local.update(s);
                e.1[..W].copy_from_slice(&local.w);
                e.2 = local.seen;
            }
            None => {
                let mut local = *m;
                self.cost += cost(&local) as u64;
                local.update(s);
                let mut w = [0; OVERLAY_W];
                w[..W].copy_from_slice(&local.w);
                self.cdfs.push((key, w, local.seen));
            }
        }
    }
}

impl SymbolSink for OverlayCostSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        let key = m as *const BinModel as usize;
        let e = match self.bins.iter().position(|e| e.0 == key) {
            Some(i) => &mut self.bins[i].1,
            None => {
                self.bins.push((key, *m));
                &mut self.bins.last_mut().expect("just pushed").1
            }
        };
        self.cost += e.cost(bit) as u64;
        e.update(bit);
    }

    #[inline]
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize) {
        self.price(m, s, |c| c.cost(s));
    }

    #[inline]
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool) {
        self.price(m, t, |c| c.signed_cost(t, negative));
    }

    #[inline]
    fn raw(&mut self, _v: u32, bits: u32) {
        self.cost += 256 * bits as u64;
    }
}
