//! Averages images of one size pixel by pixel: a reference from several
//! independent renders (different seeds) of equal length, whose noise is
//! then the single render's over the square root of their number.
//!
//!     cargo run --release --example average -- out.exr a.exr b.exr [more.exr ...]

use std::path::Path;

use caustix::Image;

const USAGE: &str = "usage: average OUT.exr IN.exr [IN.exr ...]";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [output, inputs @ ..] = args.as_slice() else { return Err(USAGE.into()) };
    if inputs.is_empty() {
        return Err(USAGE.into());
    }
    let mut sum = Image::load(Path::new(&inputs[0]))?;
    for input in &inputs[1..] {
        let image = Image::load(Path::new(input))?;
        if (image.width, image.height) != (sum.width, sum.height) {
            return Err(format!(
                "{input} is {}x{}, {} is {}x{}: the images must have one size",
                image.width, image.height, inputs[0], sum.width, sum.height
            )
            .into());
        }
        for (s, p) in sum.pixels.iter_mut().zip(&image.pixels) {
            *s += *p;
        }
    }
    let scale = 1.0 / inputs.len() as f32;
    for s in &mut sum.pixels {
        *s *= scale;
    }
    sum.save(Path::new(output), 0.0)?;
    println!("wrote {output}, the mean of {} images", inputs.len());
    Ok(())
}
