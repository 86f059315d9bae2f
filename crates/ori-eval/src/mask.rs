//! Pixel sets as bitsets: how subsets of impostors are combined without re-rendering.

/// A set of pixels of a `size` x `size` image, one bit per pixel in row-major order.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Mask {
    size: u32,
    words: Vec<u64>,
}

impl Mask {
    /// The empty set.
    pub fn new(size: u32) -> Mask {
        let bits = size as usize * size as usize;
        Mask {
            size,
            words: vec![0; bits.div_ceil(64)],
        }
    }

    /// Every pixel.
    pub fn full(size: u32) -> Mask {
        let bits = size as usize * size as usize;
        let mut words = vec![u64::MAX; bits.div_ceil(64)];
        if let Some(last) = words.last_mut()
            && !bits.is_multiple_of(64)
        {
            *last = (1 << (bits % 64)) - 1;
        }
        Mask { size, words }
    }

    /// Image edge in pixels.
    pub fn size(&self) -> u32 {
        self.size
    }

    /// Whether pixel `i` (row-major index) is in the set.
    pub fn get(&self, i: usize) -> bool {
        self.words[i / 64] >> (i % 64) & 1 != 0
    }

    /// Add pixel `i`.
    pub fn set(&mut self, i: usize) {
        self.words[i / 64] |= 1 << (i % 64);
    }

    /// Number of pixels in the set.
    pub fn count(&self) -> u32 {
        self.words.iter().map(|w| w.count_ones()).sum()
    }

    /// `self |= other`.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn union_with(&mut self, other: &Mask) {
        assert_eq!(self.size, other.size, "masks of different sizes");
        for (a, b) in self.words.iter_mut().zip(&other.words) {
            *a |= b;
        }
    }

    /// `self = self \ other`.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn remove(&mut self, other: &Mask) {
        assert_eq!(self.size, other.size, "masks of different sizes");
        for (a, b) in self.words.iter_mut().zip(&other.words) {
            *a &= !b;
        }
    }

    /// The number of pixels in `self` and not in `other`: `|self \ other|`.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn count_minus(&self, other: &Mask) -> u32 {
        assert_eq!(self.size, other.size, "masks of different sizes");
        self.words
            .iter()
            .zip(&other.words)
            .map(|(a, b)| (a & !b).count_ones())
            .sum()
    }

    /// Row-major indices of the pixels in the set, in increasing order.
    pub fn ones(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(w, &word)| {
            let mut bits = word;
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    w * 64 + b
                })
            })
        })
    }

    /// The smallest box `[x0, x1, y0, y1]` (inclusive) holding every pixel in the set; `None`
    /// when it is empty.
    pub(crate) fn bounds(&self) -> Option<[usize; 4]> {
        let n = self.size as usize;
        self.ones().fold(None, |bounds, i| {
            let (x, y) = (i % n, i / n);
            Some(match bounds {
                None => [x, x, y, y],
                Some([x0, x1, y0, y1]) => [x0.min(x), x1.max(x), y0.min(y), y1.max(y)],
            })
        })
    }

    /// Indices of the pixels in the set within `start..end`, in increasing order.
    pub fn ones_in(&self, start: usize, end: usize) -> impl Iterator<Item = usize> + '_ {
        let end = end.min(self.size as usize * self.size as usize);
        let (w0, w1) = (start / 64, end.div_ceil(64));
        (w0..w1.max(w0)).flat_map(move |w| {
            let mut bits = self.words[w];
            if w == start / 64 {
                bits &= u64::MAX << (start % 64);
            }
            if w == end / 64 {
                bits &= !(u64::MAX << (end % 64));
            }
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    w * 64 + b
                })
            })
        })
    }

    /// The 64-bit words, pixel `i` at bit `i % 64` of word `i / 64`; bits past `size^2` are 0.
    pub fn words(&self) -> &[u64] {
        &self.words
    }
}

/// What is known of one impostor's coverage mask in one view, when it is traced only at the
/// pixels asked for: the pixels traced, and those of them it covers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartialMask {
    traced: Mask,
    covered: Mask,
}

impl PartialMask {
    /// Nothing traced yet, in a view `size` pixels across.
    pub fn new(size: u32) -> PartialMask {
        PartialMask {
            traced: Mask::new(size),
            covered: Mask::new(size),
        }
    }

    /// The pixels traced so far.
    pub fn traced(&self) -> &Mask {
        &self.traced
    }

    /// The pixels traced so far that the impostor covers.
    pub fn covered(&self) -> &Mask {
        &self.covered
    }

    /// Remove from `open` the pixels the impostor covers, after tracing it at those of `open`
    /// not traced yet (`trace(pixels)`: the pixels of `pixels` it covers).
    ///
    /// The error of a union (the pixels of a reference no member covers) is then found by
    /// removing each member's known pixels from the reference and calling this for each
    /// member in turn: a member is traced only where the ones before it do not cover, each
    /// pixel at most once, and the pixels left are those no member covers.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn uncover(&mut self, open: &mut Mask, trace: impl FnOnce(&Mask) -> Mask) {
        let mut todo = open.clone();
        todo.remove(&self.traced);
        if todo.count() > 0 {
            self.covered.union_with(&trace(&todo));
            self.traced.union_with(&todo);
        }
        open.remove(&self.covered);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_union_traced_where_needed_misses_what_the_full_masks_miss() {
        let size = 16;
        let pixels = (size * size) as usize;
        // Three impostors' full masks and a reference, from a fixed pattern.
        let full: Vec<Mask> = (0..3)
            .map(|k| {
                let mut m = Mask::new(size);
                (0..pixels)
                    .filter(|i| (i * 7 + k * 13) % 5 != 0)
                    .for_each(|i| m.set(i));
                m
            })
            .collect();
        let mut reference = Mask::new(size);
        (0..pixels)
            .filter(|i| i % 3 != 0)
            .for_each(|i| reference.set(i));
        let mut known: Vec<PartialMask> = (0..3).map(|_| PartialMask::new(size)).collect();
        let mut traced = [0u32; 3];
        for members in [&[0, 1][..], &[2], &[1, 2], &[0, 1, 2], &[2, 0]] {
            let mut union = Mask::new(size);
            members.iter().for_each(|&m| union.union_with(&full[m]));
            let mut open = reference.clone();
            members
                .iter()
                .for_each(|&m| open.remove(known[m].covered()));
            for &m in members {
                known[m].uncover(&mut open, |todo| {
                    traced[m] += todo.count();
                    let mut got = Mask::new(size);
                    todo.ones()
                        .filter(|&i| full[m].get(i))
                        .for_each(|i| got.set(i));
                    got
                });
            }
            assert_eq!(open.count(), reference.count_minus(&union), "{members:?}");
        }
        // No pixel was traced twice for the same impostor.
        for (m, k) in known.iter().enumerate() {
            assert_eq!(traced[m], k.traced().count());
            assert!(k.traced().count() <= reference.count());
        }
    }

    #[test]
    fn set_count_union_and_difference() {
        let mut a = Mask::new(10);
        let mut b = Mask::new(10);
        for i in [0, 63, 64, 99] {
            a.set(i);
        }
        for i in [63, 70] {
            b.set(i);
        }
        assert_eq!(a.count(), 4);
        assert_eq!(a.count_minus(&b), 3);
        let mut rest = a.clone();
        rest.remove(&b);
        assert_eq!(rest.ones().collect::<Vec<_>>(), [0, 64, 99]);
        assert_eq!(a.ones().collect::<Vec<_>>(), [0, 63, 64, 99]);
        assert_eq!(a.ones_in(1, 99).collect::<Vec<_>>(), [63, 64]);
        assert_eq!(a.ones_in(64, 100).collect::<Vec<_>>(), [64, 99]);
        assert_eq!(a.ones_in(0, 64).collect::<Vec<_>>(), [0, 63]);
        a.union_with(&b);
        assert_eq!(a.count(), 5);
        assert!(a.get(70) && !a.get(71));
        assert_eq!(a.words().len(), 2);
    }
}
