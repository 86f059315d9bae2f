//! Pull-push fill: gives every empty texel the weighted average of the nearest non-empty
//! region, so texture filtering and mipmaps never pull background colour into a silhouette.
//! Linear in the number of texels, unlike repeated dilation.

/// Fill the entries of `values` whose weight is 0, in place. `size` x `size` grid, row-major.
/// With no weighted entry at all, everything is set to `default`.
pub(crate) fn pull_push<const C: usize>(
    size: usize,
    values: &mut [[f32; C]],
    weights: &[f32],
    default: [f32; C],
) {
    // Pull: pyramid of weighted sums.
    let mut levels: Vec<(usize, Vec<[f32; C]>, Vec<f32>)> = Vec::new();
    let base_sums: Vec<[f32; C]> = values
        .iter()
        .zip(weights)
        .map(|(v, &w)| v.map(|x| x * w))
        .collect();
    levels.push((size, base_sums, weights.to_vec()));
    while levels.last().is_some_and(|l| l.0 > 1) {
        let (n, sums, ws) = levels.last().unwrap();
        let m = n.div_ceil(2);
        let mut s2 = vec![[0.0f32; C]; m * m];
        let mut w2 = vec![0.0f32; m * m];
        for y in 0..*n {
            for x in 0..*n {
                let (i, j) = (y * n + x, (y / 2) * m + x / 2);
                for k in 0..C {
                    s2[j][k] += sums[i][k];
                }
                w2[j] += ws[i];
            }
        }
        levels.push((m, s2, w2));
    }
    // Push: each level's empty texels take their parent's average.
    let mut parent: Vec<[f32; C]> = {
        let (_, s, w) = levels.last().unwrap();
        vec![if w[0] > 0.0 {
            s[0].map(|x| x / w[0])
        } else {
            default
        }]
    };
    for level in (0..levels.len() - 1).rev() {
        let (n, sums, ws) = &levels[level];
        let m = n.div_ceil(2);
        let filled: Vec<[f32; C]> = (0..n * n)
            .map(|i| {
                if ws[i] > 0.0 {
                    sums[i].map(|x| x / ws[i])
                } else {
                    parent[((i / n) / 2) * m + (i % n) / 2]
                }
            })
            .collect();
        parent = filled;
    }
    for (i, v) in values.iter_mut().enumerate() {
        if weights[i] == 0.0 {
            *v = parent[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_texels_take_nearby_values_and_covered_ones_stay() {
        let n = 8;
        let mut v = vec![[0.0f32; 1]; n * n];
        let mut w = vec![0.0f32; n * n];
        v[0] = [1.0];
        w[0] = 1.0;
        v[n * n - 1] = [3.0];
        w[n * n - 1] = 1.0;
        pull_push(n, &mut v, &w, [9.0]);
        assert_eq!(v[0], [1.0]);
        assert_eq!(v[n * n - 1], [3.0]);
        assert_eq!(v[1], [1.0], "the neighbour of the top-left value");
        assert_eq!(v[n * n - 2], [3.0]);
        assert!(v.iter().all(|x| x[0] >= 1.0 && x[0] <= 3.0));
        let mut e = vec![[0.0f32; 1]; 4];
        pull_push(2, &mut e, &[0.0; 4], [9.0]);
        assert!(e.iter().all(|x| x[0] == 9.0));
    }
}
