//! Drawing on a [`Picture`] for figures a person reads (loss curves, rig previews): opaque pixels,
//! straight lines, and text in a built-in 3×5 pixel font (so no font file is needed).

use super::Picture;

/// Sets pixel `(x, y)` to the opaque colour `c` (nothing outside the picture).
pub fn put(pic: &mut Picture, x: i64, y: i64, c: [f32; 3]) {
    if x >= 0 && y >= 0 && x < i64::from(pic.width) && y < i64::from(pic.height) {
        pic.pixels[(y * i64::from(pic.width) + x) as usize] = [c[0], c[1], c[2], 1.0];
    }
}

/// A one-pixel line from `a` to `b` (both included).
pub fn line(pic: &mut Picture, a: [i64; 2], b: [i64; 2], c: [f32; 3]) {
    let n = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()).max(1);
    for i in 0..=n {
        put(pic, a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n, c);
    }
}

/// A filled disc of radius `r` at `centre`.
pub fn dot(pic: &mut Picture, centre: [f32; 2], r: f32, c: [f32; 3]) {
    let (x0, y0) = ((centre[0] - r).floor() as i64, (centre[1] - r).floor() as i64);
    let (x1, y1) = ((centre[0] + r).ceil() as i64, (centre[1] + r).ceil() as i64);
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (x as f32 + 0.5 - centre[0]).hypot(y as f32 + 0.5 - centre[1]) <= r {
                put(pic, x, y, c);
            }
        }
    }
}

/// Draws `s` with a 3×5 font, top-left at `at`, 4 px advance; upper case is drawn as lower case
/// and characters without a glyph as a blank.
pub fn text(pic: &mut Picture, s: &str, at: [i64; 2], c: [f32; 3]) {
    for (i, ch) in s.chars().enumerate() {
        let Some(rows) = glyph(ch.to_ascii_lowercase()) else { continue };
        for (y, row) in rows.iter().enumerate() {
            for x in 0..3 {
                if row & (4 >> x) != 0 {
                    put(pic, at[0] + 4 * i as i64 + x, at[1] + y as i64, c);
                }
            }
        }
    }
}

/// Rows of a 3×5 glyph, most significant of the 3 bits on the left.
fn glyph(ch: char) -> Option<[u8; 5]> {
    Some(match ch {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 3, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '-' => [0, 0, 7, 0, 0],
        '_' => [0, 0, 0, 0, 7],
        '.' => [0, 0, 0, 0, 2],
        ':' => [0, 2, 0, 2, 0],
        '/' => [1, 1, 2, 4, 4],
        '>' => [4, 2, 1, 2, 4],
        '%' => [5, 1, 2, 4, 5],
        'a' => [0, 6, 3, 5, 7],
        'b' => [4, 6, 5, 5, 6],
        'c' => [0, 7, 4, 4, 7],
        'd' => [1, 3, 5, 5, 3],
        'e' => [2, 5, 7, 4, 3],
        'f' => [3, 4, 6, 4, 4],
        'g' => [0, 7, 5, 3, 6],
        'h' => [4, 6, 5, 5, 5],
        'i' => [2, 0, 2, 2, 2],
        'j' => [1, 0, 1, 5, 7],
        'k' => [4, 5, 6, 5, 5],
        'l' => [6, 2, 2, 2, 7],
        'm' => [0, 7, 7, 5, 5],
        'n' => [0, 6, 5, 5, 5],
        'o' => [0, 7, 5, 5, 7],
        'p' => [0, 7, 5, 7, 4],
        'q' => [0, 7, 5, 7, 1],
        'r' => [0, 7, 4, 4, 4],
        's' => [0, 7, 6, 1, 7],
        't' => [2, 7, 2, 2, 3],
        'u' => [0, 5, 5, 5, 7],
        'v' => [0, 5, 5, 5, 2],
        'w' => [0, 5, 5, 7, 7],
        'x' => [0, 5, 2, 2, 5],
        'y' => [0, 5, 7, 1, 6],
        'z' => [0, 7, 1, 4, 7],
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_lines_and_dots_mark_the_pixels_they_should() {
        let mut pic = Picture::filled(20, 10, [1.0; 4]);
        text(&mut pic, "l1", [1, 1], [0.0; 3]);
        // 'l' row 0 is 110: pixels (1, 1) and (2, 1) set, (3, 1) not.
        assert_eq!(pic.get(1, 1), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(pic.get(3, 1), [1.0; 4]);
        line(&mut pic, [0, 9], [19, 9], [1.0, 0.0, 0.0]);
        assert!((0..20).all(|x| pic.get(x, 9) == [1.0, 0.0, 0.0, 1.0]));
        dot(&mut pic, [15.0, 4.0], 2.0, [0.0, 0.0, 1.0]);
        assert_eq!(pic.get(15, 4), [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(pic.get(19, 0), [1.0; 4]);
    }
}
