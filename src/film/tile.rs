//! Tiles: a region of a render saved as OpenEXR, with where it belongs and
//! what it was rendered from, and the merge of tiles back into one image.
//!
//! A tile is a standard EXR whose display window is the whole image and
//! whose data window is the tile's region (any EXR viewer places it), plus
//! two header attributes: `caustix.render`, the fingerprint of the scene and
//! settings it was rendered with ([`fingerprint`]), and `caustix.scene`, the
//! scene file's name, for messages. Pixels are 32-bit floats, stored
//! losslessly: merged tiles are bit-identical to one whole render.

use std::path::{Path, PathBuf};

use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::prelude::{
    Encoding, Image as ExrImage, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage,
};
use glam::Vec3;

use crate::config::{Region, RenderConfig};
use crate::error::{Error, Result};
use crate::film::Image;
use crate::scene::Scene;

const RENDER_KEY: &str = "caustix.render";
const SCENE_KEY: &str = "caustix.scene";

/// A region of an image, read from a tile file.
#[derive(Debug, Clone)]
pub struct Tile {
    /// The region's pixels.
    pub image: Image,
    /// Where they belong.
    pub region: Region,
    /// The whole image's width and height.
    pub size: (u32, u32),
    /// What it was rendered from ([`fingerprint`]).
    pub render: u64,
    /// The scene file it was rendered from.
    pub scene: String,
}

/// The fingerprint of a render: the scene ([`Scene::fingerprint`]), its
/// camera and every setting but the region (and denoising, which is
/// applied after merging). Tiles merge only with tiles of the same one.
pub fn fingerprint(scene: &Scene, config: &RenderConfig) -> u64 {
    let whole = RenderConfig { region: None, denoise: false, ..config.clone() };
    let mut h = crate::hash::Fnv64::default();
    h.u64(scene.fingerprint()).bytes(format!("{:?}{whole:?}", scene.camera).as_bytes());
    h.finish()
}

/// Writes `image`, the `region` of a render of `scene` with `config`, to
/// `path` as a tile (an `.exr` file).
pub fn save(path: &Path, image: &Image, scene: &Scene, config: &RenderConfig) -> Result<()> {
    let region = config.region();
    let fail = |message: String| Error::Image { path: path.to_path_buf(), message };
    if !Image::holds_radiance(path) || !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        return Err(fail("a tile is written as OpenEXR: name the file .exr".into()));
    }
    let width = region.width() as usize;
    let mut attributes =
        LayerAttributes { layer_position: Vec2(region.x0 as i32, region.y0 as i32), ..Default::default() };
    // The two attributes go to two maps, the layer's and the image's (one
    // header either way): the `exr` crate writes a map in no fixed order,
    // and with both in one map the same tile came out as different bytes
    // from run to run.
    attributes.other.insert(
        Text::from(RENDER_KEY),
        AttributeValue::Text(Text::from(format!("{:016x}", fingerprint(scene, config)).as_str())),
    );
    let name = scene.path.file_name().unwrap_or_default().to_string_lossy().into_owned();
    let layer = Layer::new(
        (width, region.height() as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        SpecificChannels::rgb(|p: Vec2<usize>| {
            let v = image.pixels[p.y() * width + p.x()];
            (v.x, v.y, v.z)
        }),
    );
    let mut exr = ExrImage::from_layer(layer);
    exr.attributes.display_window =
        IntegerBounds::new((0, 0), (config.width as usize, config.height as usize));
    exr.attributes
        .other
        .insert(Text::from(SCENE_KEY), AttributeValue::Text(Text::new_or_panic(ascii(&name))));
    let mut bytes = std::io::Cursor::new(Vec::new());
    exr.write().to_buffered(&mut bytes).map_err(|e| fail(format!("cannot encode the tile: {e}")))?;
    crate::files::write_whole(path, bytes.get_ref())
}

/// `text` with anything outside printable ASCII replaced (EXR text attributes).
fn ascii(text: &str) -> String {
    text.chars().map(|c| if c.is_ascii_graphic() || c == ' ' { c } else { '_' }).collect()
}

/// Reads a tile written by [`save`].
pub fn load(path: &Path) -> Result<Tile> {
    crate::files::check_regular(path)?;
    let bad = |message: String| Error::input(path, message);
    let exr = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |resolution, _| (resolution.width(), vec![Vec3::ZERO; resolution.width() * resolution.height()]),
        |(width, pixels), p, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[p.y() * *width + p.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| bad(format!("cannot read it as OpenEXR: {e}")))?;
    let text = |key: &str| match exr
        .layer_data
        .attributes
        .other
        .get(&Text::from(key))
        .or(exr.attributes.other.get(&Text::from(key)))
    {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    };
    let not_a_tile = || {
        bad("not a caustix tile (no caustix.render attribute): render tiles with `caustix render --tile I/N` or `--crop`".into())
    };
    let render = text(RENDER_KEY).ok_or_else(not_a_tile)?;
    let render = u64::from_str_radix(&render, 16).map_err(|_| not_a_tile())?;
    let display = exr.attributes.display_window;
    let position = exr.layer_data.attributes.layer_position;
    let (width, pixels) = exr.layer_data.channel_data.pixels;
    let height = pixels.len() / width.max(1);
    let (x0, y0) = (position.x(), position.y());
    let (full_w, full_h) = (display.size.width(), display.size.height());
    if display.position != Vec2(0, 0)
        || x0 < 0
        || y0 < 0
        || x0 as usize + width > full_w
        || y0 as usize + height > full_h
    {
        return Err(bad(format!(
            "its region ({x0}, {y0}) + {width}x{height} does not lie inside its {full_w}x{full_h} image"
        )));
    }
    let region = Region {
        x0: x0 as u32,
        y0: y0 as u32,
        x1: (x0 as usize + width) as u32,
        y1: (y0 as usize + height) as u32,
    };
    Ok(Tile {
        image: Image { width: width as u32, height: height as u32, pixels },
        region,
        size: (full_w as u32, full_h as u32),
        render,
        scene: text(SCENE_KEY).unwrap_or_default(),
    })
}

/// Assembles tiles into the whole image, checking that they come from the
/// same render (scene, settings, image size) and cover every pixel exactly
/// once; the errors name the tiles.
pub fn merge(tiles: &[(PathBuf, Tile)]) -> Result<Image> {
    let Some((first_path, first)) = tiles.first() else {
        return Err(Error::Setting { name: "tiles", message: "none given".into() });
    };
    let mismatch = |path: &Path, what: String| {
        Error::input(path, format!("{what} than {}: tiles of different renders", first_path.display()))
    };
    for (path, tile) in &tiles[1..] {
        if tile.size != first.size {
            return Err(mismatch(
                path,
                format!("a tile of a {}x{} image, another size", tile.size.0, tile.size.1),
            ));
        }
        if tile.render != first.render {
            return Err(mismatch(
                path,
                format!("rendered from another scene ({}) or with other settings", tile.scene),
            ));
        }
    }
    let (width, height) = first.size;
    let mut image = Image { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] };
    // Which tile wrote each pixel.
    let mut owner: Vec<Option<usize>> = vec![None; image.pixels.len()];
    for (t, (path, tile)) in tiles.iter().enumerate() {
        let r = tile.region;
        for (i, value) in tile.image.pixels.iter().enumerate() {
            let (x, y) = r.pixel(i);
            let at = (y * width + x) as usize;
            if let Some(other) = owner[at] {
                return Err(Error::input(
                    path,
                    format!(
                        "overlaps {} at pixel ({x}, {y}): a tile given twice, or tiles of different splits",
                        tiles[other].0.display()
                    ),
                ));
            }
            owner[at] = Some(t);
            image.pixels[at] = *value;
        }
    }
    // The uncovered pixels, by index: the first and last give the rows.
    let uncovered: Vec<usize> =
        owner.iter().enumerate().filter(|(_, o)| o.is_none()).map(|(i, _)| i).collect();
    if let (Some(&first), Some(&last)) = (uncovered.first(), uncovered.last()) {
        let (x, y) = (first as u32 % width, first as u32 / width);
        let last_row = last as u32 / width;
        return Err(Error::input(
            first_path,
            format!(
                "the tiles leave {} pixels of the {width}x{height} image uncovered, the first at ({x}, {y}), \
                 in rows {y} to {last_row}: a tile is missing",
                uncovered.len()
            ),
        ));
    }
    Ok(image)
}
