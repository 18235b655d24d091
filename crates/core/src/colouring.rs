//! Graph colouring for parallel Gauss–Seidel: items of one colour share no edge, so a sweep
//! can update all of them at once and the result is that of a sequential sweep in colour
//! order, whatever the thread count.
//!
//! Greedy first-fit in index order: deterministic, at most (largest degree + 1) colours.
//! Vertex block descent colours free vertices (edges: the Hessian's block pattern, i.e. shared
//! tets and springs); XPBD colours constraints (edges: a shared vertex); the AMG smoother
//! colours the nodes of each level (edges: a nonzero block of the level's matrix).

/// A colouring of `n` items: the colour of each and the items of each colour in index order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Colouring {
    colour: Vec<u32>,
    ptr: Vec<usize>,
    items: Vec<usize>,
}

impl Colouring {
    /// Greedy first-fit colouring of items `0..n`; `neighbours(i, visit)` calls `visit(j)`
    /// for every item `j` adjacent to `i` (`j == i` and repeats are allowed and ignored).
    pub fn greedy(n: usize, neighbours: impl Fn(usize, &mut dyn FnMut(usize))) -> Self {
        const NONE: u32 = u32::MAX;
        let mut colour = vec![NONE; n];
        // forbidden[c] == i + 1: colour c is taken by a neighbour of item i.
        let mut forbidden: Vec<usize> = Vec::new();
        for i in 0..n {
            neighbours(i, &mut |j| {
                let c = colour[j];
                if j != i && c != NONE {
                    forbidden[c as usize] = i + 1;
                }
            });
            let c = (0..forbidden.len())
                .find(|&c| forbidden[c] != i + 1)
                .unwrap_or(forbidden.len());
            if c == forbidden.len() {
                forbidden.push(0);
            }
            colour[i] = u32::try_from(c).expect("fewer than u32::MAX colours");
        }
        let num_colours = forbidden.len();
        let mut ptr = vec![0usize; num_colours + 1];
        for &c in &colour {
            ptr[c as usize + 1] += 1;
        }
        for c in 0..num_colours {
            ptr[c + 1] += ptr[c];
        }
        let mut fill = ptr.clone();
        let mut items = vec![0usize; n];
        for (i, &c) in colour.iter().enumerate() {
            items[fill[c as usize]] = i;
            fill[c as usize] += 1;
        }
        Self { colour, ptr, items }
    }

    /// Number of colours.
    pub fn num_colours(&self) -> usize {
        self.ptr.len().saturating_sub(1)
    }

    /// Number of coloured items.
    pub fn len(&self) -> usize {
        self.colour.len()
    }

    /// Whether there are no items.
    pub fn is_empty(&self) -> bool {
        self.colour.is_empty()
    }

    /// The colour of item `i`.
    pub fn colour_of(&self, i: usize) -> usize {
        self.colour[i] as usize
    }

    /// The items of colour `c`, in increasing index order.
    pub fn group(&self, c: usize) -> &[usize] {
        &self.items[self.ptr[c]..self.ptr[c + 1]]
    }

    /// Where group `c` starts in the concatenation of the groups in colour order.
    pub fn group_start(&self, c: usize) -> usize {
        self.ptr[c]
    }

    /// The size of the largest colour group.
    pub fn largest_group(&self) -> usize {
        self.ptr.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0)
    }

    /// The first pair of distinct adjacent items that share a colour, if any (`None`: the
    /// colouring is valid for this adjacency).
    pub fn conflict(
        &self,
        neighbours: impl Fn(usize, &mut dyn FnMut(usize)),
    ) -> Option<(usize, usize)> {
        let mut found = None;
        for i in 0..self.len() {
            neighbours(i, &mut |j| {
                if found.is_none() && j != i && self.colour[j] == self.colour[i] {
                    found = Some((i, j));
                }
            });
            if found.is_some() {
                break;
            }
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cycle_of_five_needs_three_colours_and_is_valid() {
        let adj = |i: usize, visit: &mut dyn FnMut(usize)| {
            visit((i + 1) % 5);
            visit((i + 4) % 5);
        };
        let c = Colouring::greedy(5, adj);
        assert_eq!(c.num_colours(), 3);
        assert_eq!(c.conflict(adj), None);
        let total: usize = (0..c.num_colours()).map(|k| c.group(k).len()).sum();
        assert_eq!(total, 5);
    }

    #[test]
    fn a_wrong_colouring_is_reported() {
        let c = Colouring::greedy(2, |_, _| {});
        assert_eq!(c.num_colours(), 1);
        assert_eq!(
            c.conflict(|i, visit: &mut dyn FnMut(usize)| visit(1 - i)),
            Some((0, 1))
        );
    }
}
