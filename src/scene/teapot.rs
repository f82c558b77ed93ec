//! Bicubic Bezier patches (`.bpt` files) and their tessellation: the Utah
//! teapot (Newell 1975), whose data lives in `scenes/data/teapot.bpt`.
//!
//! Format: a patch count, then per patch its degrees (`3 3`) and 16 control
//! points row by row, all whitespace-separated. The surface is
//! `S(u, v) = sum_r sum_c B_r(v) B_c(u) P[4r + c]`.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Location, Result};

/// The teapot's patch data, built in so scenes can use it from anywhere.
pub const TEAPOT_BPT: &str = include_str!("../../scenes/data/teapot.bpt");

/// One bicubic Bezier patch: 16 control points, row by row (`P[4r + c]`).
pub type Patch = [Vec3; 16];

/// Reads `.bpt` text. `path` only names the file in error messages.
pub fn parse_bpt(text: &str, path: &Path) -> Result<Vec<Patch>> {
    let mut tokens = Tokens::new(text, path);
    let count = tokens.integer("the patch count")?;
    if count == 0 {
        return Err(tokens.error_here("the file declares 0 patches; a .bpt file needs at least one"));
    }
    let mut patches = Vec::with_capacity(count.min(1 << 20));
    for patch in 1..=count {
        let (du, dv) = (tokens.integer("a patch degree")?, tokens.integer("a patch degree")?);
        if (du, dv) != (3, 3) {
            return Err(tokens.error_at_last(format!(
                "patch {patch} has degrees {du} {dv}; only bicubic patches (3 3) are supported"
            )));
        }
        let mut points = [Vec3::ZERO; 16];
        for p in &mut points {
            *p = Vec3::new(tokens.number()?, tokens.number()?, tokens.number()?);
        }
        patches.push(points);
    }
    if let Some((offset, extra)) = tokens.next_raw() {
        return Err(Error::input_at(
            path,
            Location::from_offset(text, offset),
            format!("unexpected `{extra}` after the {count} declared patches"),
        ));
    }
    Ok(patches)
}

/// Whitespace-separated tokens with their byte offsets, for error locations.
struct Tokens<'a> {
    text: &'a str,
    path: &'a Path,
    iter: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
    last: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str, path: &'a Path) -> Self {
        let iter: Box<dyn Iterator<Item = (usize, &'a str)>> = Box::new(
            text.split_ascii_whitespace().map(move |t| (t.as_ptr() as usize - text.as_ptr() as usize, t)),
        );
        Tokens { text, path, iter: iter.peekable(), last: 0 }
    }

    fn next_raw(&mut self) -> Option<(usize, &'a str)> {
        let next = self.iter.next()?;
        self.last = next.0;
        Some(next)
    }

    fn next_token(&mut self, what: &str) -> Result<&'a str> {
        match self.next_raw() {
            Some((_, t)) => Ok(t),
            None => Err(self.error_here(format!("the file ends where {what} was expected"))),
        }
    }

    fn integer(&mut self, what: &str) -> Result<usize> {
        let token = self.next_token(what)?;
        token
            .parse()
            .map_err(|_| self.error_at_last(format!("expected {what} (a whole number), found `{token}`")))
    }

    fn number(&mut self) -> Result<f32> {
        let token = self.next_token("a control point coordinate")?;
        match token.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(self.error_at_last(format!("expected a finite coordinate, found `{token}`"))),
        }
    }

    fn error_at_last(&self, message: impl Into<String>) -> Error {
        Error::input_at(self.path, Location::from_offset(self.text, self.last), message)
    }

    fn error_here(&self, message: impl Into<String>) -> Error {
        Error::input_at(self.path, Location::from_offset(self.text, self.text.trim_end().len()), message)
    }
}

/// Cubic Bernstein weights at `t = i / n`, computed so that the weights at
/// `n - i` are exactly those at `i` reversed (floating-point products are
/// commutative but not associative, so the grouping below matters).
fn bernstein(i: usize, n: usize) -> [f32; 4] {
    let t = i as f32 / n as f32;
    let s = (n - i) as f32 / n as f32;
    [(s * s) * s, (s * s) * (3.0 * t), (3.0 * s) * (t * t), (t * t) * t]
}

/// `w0 p0 + w1 p1 + w2 p2 + w3 p3`, summed in an order that is the same for
/// the reversed sequence: a curve shared by two patches evaluates to
/// bit-identical points from either side, in either direction.
///
/// A row collapsed to one point (the poles of the knob and the bottom) gives
/// exactly that point: the weights' sum is 1 only up to rounding, and a pole
/// smeared over several nearby positions would leave sliver triangles there.
fn blend(w: [f32; 4], p: [Vec3; 4]) -> Vec3 {
    if p[1] == p[0] && p[2] == p[0] && p[3] == p[0] {
        return p[0];
    }
    (w[0] * p[0] + w[3] * p[3]) + (w[1] * p[1] + w[2] * p[2])
}

/// Tessellates patches into `level x level` quads each (two triangles per
/// quad), welding vertices at bit-identical positions on patch borders so
/// seams between patches are shared edges. Triangles collapsed at a pole (a
/// degenerate control row) come out with repeated indices; [`super::mesh::Mesh::new`]
/// drops them. The counter-clockwise side is the `dS/du x dS/dv` side.
///
/// Patches are evaluated in parallel. Only border points are looked up for
/// welding (a few per patch edge, not the whole grid): an interior point of
/// one patch is never a point of another, and were two interior points of one
/// patch equal, their triangles would have zero area and be dropped anyway.
pub fn tessellate(patches: &[Patch], level: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let level = level.max(1);
    let side = level + 1;
    let weights: Vec<[f32; 4]> = (0..=level).map(|i| bernstein(i, level)).collect();
    let grids: Vec<Vec<Vec3>> = patches.par_iter().map(|patch| evaluate_grid(patch, &weights)).collect();

    let mut border_index: HashMap<[u32; 3], u32> = HashMap::new();
    // One spare slot: Mesh::new pads the positions for Embree (no copy then).
    let mut positions = Vec::with_capacity(patches.len() * side * side + 1);
    let mut indices = Vec::with_capacity(patches.len() * level * level * 2);
    let mut grid_index = vec![0u32; side * side];
    for grid in grids {
        for (k, p) in grid.into_iter().enumerate() {
            let (i, j) = (k % side, k / side);
            let next = positions.len() as u32;
            grid_index[k] = if i == 0 || j == 0 || i == level || j == level {
                *border_index.entry(p.to_array().map(f32::to_bits)).or_insert_with(|| {
                    positions.push(p);
                    next
                })
            } else {
                positions.push(p);
                next
            };
        }
        let at = |i: usize, j: usize| grid_index[j * side + i];
        for j in 0..level {
            for i in 0..level {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                indices.push([a, b, c]);
                indices.push([a, c, d]);
            }
        }
    }
    (positions, indices)
}

/// The patch's points at every pair of `weights`, row by row (`v` outer).
fn evaluate_grid(patch: &Patch, weights: &[[f32; 4]]) -> Vec<Vec3> {
    let mut grid = Vec::with_capacity(weights.len() * weights.len());
    for wv in weights {
        for wu in weights {
            let rows = [0, 1, 2, 3]
                .map(|r| blend(*wu, [patch[4 * r], patch[4 * r + 1], patch[4 * r + 2], patch[4 * r + 3]]));
            // Adding +0.0 turns -0.0 into +0.0 so both weld together.
            grid.push(blend(*wv, rows) + Vec3::ZERO);
        }
    }
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bernstein_weights_sum_to_one_and_mirror_exactly() {
        for n in [1, 3, 7, 16] {
            for i in 0..=n {
                let w = bernstein(i, n);
                assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
                let mut m = bernstein(n - i, n);
                m.reverse();
                assert_eq!(w, m);
            }
        }
    }

    #[test]
    fn errors_name_the_line() {
        let p = Path::new("t.bpt");
        let err = parse_bpt("1\n3 3\n0 0 0\n1 x 0\n", p).unwrap_err().to_string();
        assert!(err.starts_with("t.bpt:4:3:") && err.contains("`x`"), "{err}");
        let err = parse_bpt("1\n3 3\n0 0 0\n", p).unwrap_err().to_string();
        assert!(err.contains("file ends"), "{err}");
        let err = parse_bpt("1\n2 3\n", p).unwrap_err().to_string();
        assert!(err.contains("only bicubic"), "{err}");
    }
}
