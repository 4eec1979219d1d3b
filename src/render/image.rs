//! Image buffers over an absolute pixel window: 8-bit grey frames and linear f32 radiance.

use super::raster::PixelRect;

/// 8-bit grey pixels of `window`, row-major (`data.len() == window.len()`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GrayImage {
    pub window: PixelRect,
    pub data: Vec<u8>,
}

/// Linear values (radiance or DN before quantisation) of `window`, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    pub window: PixelRect,
    pub data: Vec<f32>,
}

impl GrayImage {
    /// The grey level of absolute pixel (x, y), if inside the window.
    pub fn get(&self, x: i64, y: i64) -> Option<u8> {
        self.window.index(x, y).map(|i| self.data[i])
    }

    /// The part of this image inside `rect` (clipped to the window).
    pub fn crop(&self, rect: &PixelRect) -> GrayImage {
        crop(&self.data, &self.window, rect, |v| v).into_gray()
    }
}

impl LinearImage {
    pub fn get(&self, x: i64, y: i64) -> Option<f32> {
        self.window.index(x, y).map(|i| self.data[i])
    }
}

struct Cropped<T> {
    window: PixelRect,
    data: Vec<T>,
}

impl Cropped<u8> {
    fn into_gray(self) -> GrayImage {
        GrayImage {
            window: self.window,
            data: self.data,
        }
    }
}

/// Copies the `rect ∩ window` part of a row-major buffer over `window`.
pub(crate) fn crop_buffer<T: Copy>(
    data: &[T],
    window: &PixelRect,
    rect: &PixelRect,
) -> (PixelRect, Vec<T>) {
    let c = crop(data, window, rect, |v| v);
    (c.window, c.data)
}

fn crop<T: Copy>(
    data: &[T],
    window: &PixelRect,
    rect: &PixelRect,
    f: impl Fn(T) -> T,
) -> Cropped<T> {
    let r = window.intersect(rect);
    let mut out = Vec::with_capacity(r.len());
    for y in r.y0..r.y1() {
        let start = window.index(r.x0, y).unwrap_or(0);
        out.extend(data[start..start + r.width].iter().map(|&v| f(v)));
    }
    Cropped {
        window: r,
        data: out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_keeps_absolute_positions() {
        let w = PixelRect::new(10, 20, 4, 3);
        let img = GrayImage {
            window: w,
            data: (0..12).collect(),
        };
        let c = img.crop(&PixelRect::new(11, 21, 10, 1));
        assert_eq!(c.window, PixelRect::new(11, 21, 3, 1));
        assert_eq!(c.data, vec![5, 6, 7]);
        assert_eq!(c.get(12, 21), img.get(12, 21));
        assert_eq!(img.get(9, 20), None);
    }
}
