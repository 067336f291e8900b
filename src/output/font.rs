//! The font of every text blockdem draws into an image (the PLOT page's caption, axes and arrow
//! scale; the charts of `blockdem verify` and `blockdem bench`): DejaVu Sans from Debian's
//! fonts-dejavu-core (scripts/setup.sh installs it), or the TrueType file `BLOCKDEM_FONT` names.
//! Without one, images are drawn without their text and the callers say so (an SVG of a PLOT
//! carries its text in any case).

use std::sync::OnceLock;

/// Where DejaVu Sans lives on Debian and other common layouts.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
];

/// The font file's bytes (read once per process), or why there is none.
pub fn font_bytes() -> Result<&'static [u8], String> {
    static FONT: OnceLock<Result<&'static [u8], String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let mut candidates: Vec<String> = Vec::new();
        if let Ok(p) = std::env::var("BLOCKDEM_FONT") {
            candidates.push(p);
        }
        candidates.extend(FONT_PATHS.iter().map(|s| s.to_string()));
        for p in &candidates {
            if let Ok(bytes) = std::fs::read(p) {
                if ab_glyph::FontRef::try_from_slice(&bytes).is_ok() {
                    return Ok(&*Box::leak(bytes.into_boxed_slice()));
                }
            }
        }
        Err("no font for the text of images: install fonts-dejavu-core (scripts/setup.sh does) or set BLOCKDEM_FONT to a .ttf file".to_string())
    })
    .clone()
}
