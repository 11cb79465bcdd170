//! The unit-cell description (a TOML file with a text or PNG pixel pattern and its materials) and
//! its pixel meshing, shared by the cell problem (§4, [`crate::homogenize`]) and the fine
//! reference simulation (a tiled, non-periodic sheet).
//!
//! # File format
//!
//! ```toml
//! name = "stripes"            # optional; defaults to the file stem
//! size = 0.01                 # metres: width of the cell along u
//! pattern = ["####", "...."]  # one char per square pixel; row 0 is the TOP row
//! # or: pattern_image = "weave.png"  (relative to the toml's directory; materials keyed "#rrggbb")
//! [materials."#"]
//! stiffness = 1.0e3           # isotropic membrane stiffness Y, N/m ...
//! poisson = 0.3               # ... with its Poisson ratio, in (-1, 0.5)
//! density = 0.2               # kg/m²
//! bending = 1.0e-6            # N·m, optional, default DEFAULT_BENDING
//! [materials."."]
//! tensor = [[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]  # full C (Voigt), N/m
//! density = 0.1
//! ```
//!
//! A material gives either `stiffness` + `poisson` (docs/CONVENTIONS.md's isotropic `C`) or a full symmetric
//! positive definite `tensor`. Materials a pattern does not use are allowed. Materials are stored
//! sorted by key, and pixels index into that list.
//!
//! # Meshing
//!
//! The node and triangle numbering is the one of `docs/ARCHITECTURE.md` ("Pixel mesh
//! numbering"); the blob and `localize.rs` rely on it, so it must not change.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::Deserialize;

use crate::lattice;
use crate::membrane;
use crate::voigt::SpdProblem;
use crate::Voigt;

/// Bending stiffness (N·m) of a material whose `bending` key is absent: a light cotton-like
/// fabric. Bending is not homogenized by the cell problem (§4 is in-plane only); it is only
/// area-averaged, see [`crate::homogenize::Homogenized::bending`].
pub const DEFAULT_BENDING: f64 = 1.0e-6;

/// One material of a cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The key of the material in the file: a single pattern character, or `#rrggbb` (lower
    /// or upper case, as written in the file) for a PNG pattern.
    pub key: String,
    /// Membrane stiffness `C` (Voigt `[11, 22, 12]`, engineering shear), N/m. Symmetric
    /// positive definite.
    pub c: Voigt,
    /// Areal density, kg/m².
    pub density: f64,
    /// Bending stiffness, N·m.
    pub bending: f64,
}

/// A periodic unit cell: a grid of square pixels, each made of one material.
#[derive(Clone, Debug, PartialEq)]
pub struct CellDesc {
    pub name: String,
    /// Width of the cell along u, metres. Pixels are square, so the height is
    /// `size * rows / cols`.
    pub size: f64,
    pub cols: usize,
    pub rows: usize,
    /// `rows * cols` material indices, row-major; row 0 is the TOP row (largest v).
    pub pixels: Vec<u32>,
    pub materials: Vec<Material>,
}

impl CellDesc {
    /// Width along u, metres (= `size`).
    pub fn width(&self) -> f64 {
        self.size
    }

    /// Height along v, metres (= `size * rows / cols`: pixels are square).
    pub fn height(&self) -> f64 {
        if self.cols == 0 {
            return 0.0;
        }
        self.size * self.rows as f64 / self.cols as f64
    }

    /// Keys of the materials no pixel uses (allowed, but usually a typo in the pattern or a
    /// leftover; `weft-cell build` warns).
    pub fn unused_materials(&self) -> Vec<&str> {
        self.materials
            .iter()
            .enumerate()
            .filter(|(m, _)| !self.pixels.iter().any(|&p| p as usize == *m))
            .map(|(_, mat)| mat.key.as_str())
            .collect()
    }

    /// Material index of pixel `(row, col)`, row 0 at the top. Out-of-range coordinates (or a
    /// `pixels` vector shorter than `rows * cols`) give `u32::MAX`, which no material has, so
    /// the error surfaces where the index is used instead of as a panic here.
    pub fn pixel(&self, row: usize, col: usize) -> u32 {
        if row >= self.rows || col >= self.cols {
            return u32::MAX;
        }
        self.pixels
            .get(row * self.cols + col)
            .copied()
            .unwrap_or(u32::MAX)
    }
}

/// What is wrong with one material of a cell file.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialProblem {
    /// Both `stiffness` and `tensor` were given.
    BothStiffnessAndTensor,
    /// Neither `stiffness` nor `tensor` was given.
    NeitherStiffnessNorTensor,
    /// `stiffness` without `poisson`.
    MissingPoisson,
    /// `poisson` with a `tensor` (the tensor already says everything).
    PoissonWithTensor,
    /// `stiffness` is NaN, infinite, zero or negative.
    BadStiffness(f64),
    /// `poisson` is not in the open interval (-1, 0.5), where the isotropic membrane `C` is
    /// positive definite.
    PoissonOutOfRange(f64),
    /// `tensor` has a NaN or infinite entry.
    TensorNotFinite,
    /// `tensor[row][col]` (`lower`) differs from `tensor[col][row]` (`upper`) beyond decimal
    /// round-off.
    TensorNotSymmetric {
        row: usize,
        col: usize,
        lower: f64,
        upper: f64,
    },
    /// `tensor` is symmetric but not positive definite: some strain would store no energy.
    TensorNotPositiveDefinite,
    /// `density` is NaN, infinite, zero or negative.
    BadDensity(f64),
    /// `bending` is NaN, infinite or negative.
    BadBending(f64),
}

impl fmt::Display for MaterialProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BothStiffnessAndTensor => {
                write!(f, "gives both `stiffness` and `tensor`; give exactly one")
            }
            Self::NeitherStiffnessNorTensor => write!(
                f,
                "gives neither `stiffness` (+ `poisson`) nor `tensor`; give exactly one"
            ),
            Self::MissingPoisson => write!(f, "gives `stiffness` without `poisson`"),
            Self::PoissonWithTensor => {
                write!(
                    f,
                    "gives `poisson` with `tensor`; `poisson` goes with `stiffness`"
                )
            }
            Self::BadStiffness(v) => write!(f, "stiffness {v} is not a positive finite number"),
            Self::PoissonOutOfRange(v) => write!(f, "poisson {v} is outside (-1, 0.5)"),
            Self::TensorNotFinite => write!(f, "tensor has a non-finite entry"),
            Self::TensorNotSymmetric {
                row,
                col,
                lower,
                upper,
            } => write!(
                f,
                "tensor is not symmetric: tensor[{row}][{col}] = {lower} but tensor[{col}][{row}] = {upper}"
            ),
            Self::TensorNotPositiveDefinite => write!(
                f,
                "tensor is symmetric but not positive definite (a leading minor is ≤ 0): some strain would store no energy"
            ),
            Self::BadDensity(v) => write!(f, "density {v} is not a positive finite number"),
            Self::BadBending(v) => write!(f, "bending {v} is not a non-negative finite number"),
        }
    }
}

/// Everything that can be wrong with a cell file. Every variant names the file, and the key,
/// the row and column, or the TOML line where it can.
#[derive(Clone, Debug, PartialEq)]
pub enum CellError {
    /// The file (or the PNG it names) could not be read.
    Io { file: String, message: String },
    /// Not valid TOML.
    Syntax {
        file: String,
        line: Option<usize>,
        message: String,
    },
    /// A key the format does not know; `suggestion` is a known key one or two edits away.
    UnknownKey {
        file: String,
        key: String,
        line: Option<usize>,
        suggestion: Option<String>,
    },
    /// A required key is absent.
    MissingKey {
        file: String,
        key: String,
        line: Option<usize>,
    },
    /// A key has a value of the wrong type or shape (e.g. a string for `size`, a 2×3 tensor).
    BadValue {
        file: String,
        line: Option<usize>,
        message: String,
    },
    /// `size` is NaN, infinite, zero or negative.
    BadSize { file: String, size: f64 },
    /// Neither `pattern` nor `pattern_image` was given.
    NoPattern { file: String },
    /// Both `pattern` and `pattern_image` were given.
    BothPatterns { file: String },
    /// The pattern has no rows, or an empty first row (or the image has no pixels).
    EmptyPattern { file: String },
    /// A pattern row (0 = top) has a different length than row 0.
    RaggedRow {
        file: String,
        row: usize,
        len: usize,
        expected: usize,
    },
    /// A pattern character with no material.
    UnknownPatternChar {
        file: String,
        row: usize,
        col: usize,
        ch: char,
    },
    /// A material key of the wrong form: one character for a text pattern, `#rrggbb` for an
    /// image pattern (or two keys naming the same color).
    BadMaterialKey {
        file: String,
        key: String,
        reason: &'static str,
    },
    /// A material with invalid values.
    InvalidMaterial {
        file: String,
        key: String,
        problem: MaterialProblem,
    },
    /// The PNG could not be decoded.
    Image {
        file: String,
        image: String,
        message: String,
    },
    /// A PNG pixel whose color is not a material key.
    UnknownPixelColor {
        file: String,
        image: String,
        row: usize,
        col: usize,
        color: String,
    },
}

fn at_line(line: &Option<usize>) -> String {
    match line {
        Some(l) => format!(" (line {l})"),
        None => String::new(),
    }
}

impl fmt::Display for CellError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { file, message } => write!(f, "{file}: cannot read: {message}"),
            Self::Syntax {
                file,
                line,
                message,
            } => write!(f, "{file}{}: TOML syntax error: {message}", at_line(line)),
            Self::UnknownKey {
                file,
                key,
                line,
                suggestion,
            } => {
                write!(f, "{file}{}: unknown key `{key}`", at_line(line))?;
                match suggestion {
                    Some(s) => write!(f, "; did you mean `{s}`?"),
                    None => Ok(()),
                }
            }
            Self::MissingKey { file, key, line } => {
                write!(f, "{file}{}: missing key `{key}`", at_line(line))
            }
            Self::BadValue {
                file,
                line,
                message,
            } => write!(f, "{file}{}: {message}", at_line(line)),
            Self::BadSize { file, size } => {
                write!(f, "{file}: size {size} is not a positive finite number of metres")
            }
            Self::NoPattern { file } => {
                write!(f, "{file}: give one of `pattern` or `pattern_image`")
            }
            Self::BothPatterns { file } => write!(
                f,
                "{file}: give only one of `pattern` and `pattern_image`, not both"
            ),
            Self::EmptyPattern { file } => write!(f, "{file}: the pattern is empty"),
            Self::RaggedRow {
                file,
                row,
                len,
                expected,
            } => write!(
                f,
                "{file}: pattern row {row} has {len} pixels, row 0 has {expected}"
            ),
            Self::UnknownPatternChar { file, row, col, ch } => write!(
                f,
                "{file}: pattern row {row}, column {col}: character {ch:?} is not a material key"
            ),
            Self::BadMaterialKey { file, key, reason } => {
                write!(f, "{file}: material key {key:?}: {reason}")
            }
            Self::InvalidMaterial { file, key, problem } => {
                write!(f, "{file}: material {key:?} {problem}")
            }
            Self::Image {
                file,
                image,
                message,
            } => write!(f, "{file}: pattern image {image:?}: {message}"),
            Self::UnknownPixelColor {
                file,
                image,
                row,
                col,
                color,
            } => write!(
                f,
                "{file}: pattern image {image:?} row {row}, column {col}: color {color} is not a material key"
            ),
        }
    }
}

impl std::error::Error for CellError {}

/// The file as written; validated into a [`CellDesc`] by [`parse`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCell {
    name: Option<String>,
    size: f64,
    pattern: Option<Vec<String>>,
    pattern_image: Option<String>,
    materials: BTreeMap<String, RawMaterial>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    stiffness: Option<f64>,
    poisson: Option<f64>,
    tensor: Option<Voigt>,
    density: f64,
    bending: Option<f64>,
}

/// Reads and validates a cell file. A `pattern_image` is resolved relative to the file's
/// directory.
pub fn load(path: &Path) -> Result<CellDesc, CellError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| CellError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse(&text, &file, base)
}

/// 1-based line of a byte offset, for error messages.
fn line_of(text: &str, span: Option<std::ops::Range<usize>>) -> Option<usize> {
    let start = span?.start;
    let head = text.get(..start)?;
    Some(head.matches('\n').count() + 1)
}

/// The names between pairs of backticks of a serde message, in order ("unknown field `x`,
/// expected one of `a`, `b`": x, a, b).
fn backticked(message: &str) -> Vec<&str> {
    message.split('`').skip(1).step_by(2).collect()
}

/// The known key closest to a misspelled `key`, if one is at most two edits away (one for
/// keys of up to four characters, so that `size` does not suggest `name`).
fn closest<'a>(key: &str, known: &[&'a str]) -> Option<&'a str> {
    let limit = if key.chars().count() <= 4 { 1 } else { 2 };
    known
        .iter()
        .map(|k| (edit_distance(key, k), *k))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

/// Edit distance (insertions, deletions, substitutions and swaps of neighbours: the optimal
/// string alignment distance) over chars.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let at = |row: &[usize], k: usize| row.get(k).copied().unwrap_or(usize::MAX / 2);
    // Rows i-1 and i of the table d[i][j] = distance of a's first i chars to b's first j.
    let mut before: Vec<usize> = Vec::new();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, &ca) in a.iter().enumerate() {
        let mut row = Vec::with_capacity(b.len() + 1);
        row.push(i + 1);
        for (j, &cb) in b.iter().enumerate() {
            let mut best = (at(&prev, j) + usize::from(ca != cb))
                .min(at(&prev, j + 1) + 1)
                .min(at(&row, j) + 1);
            let swap = i > 0 && j > 0 && a.get(i - 1) == Some(&cb) && b.get(j - 1) == Some(&ca);
            if swap {
                best = best.min(at(&before, j - 1) + 1);
            }
            row.push(best);
        }
        before = std::mem::replace(&mut prev, row);
    }
    at(&prev, b.len())
}

/// Parses and validates cell-file text. `file_name` names the file in errors and gives the
/// default cell name (its stem); `base_dir` is where `pattern_image` is looked up.
pub fn parse(text: &str, file_name: &str, base_dir: &Path) -> Result<CellDesc, CellError> {
    let file = file_name.to_string();
    // Parse as plain TOML first so syntax errors are told apart from schema errors.
    if let Err(e) = text.parse::<toml::Table>() {
        return Err(CellError::Syntax {
            file,
            line: line_of(text, e.span()),
            message: e.message().to_string(),
        });
    }
    let raw: RawCell = toml::from_str(text).map_err(|e| {
        let line = line_of(text, e.span());
        let message = e.message().to_string();
        // serde's fixed wording for `deny_unknown_fields` and absent non-Option fields.
        let names = backticked(&message);
        match names.split_first() {
            Some((key, known)) if message.starts_with("unknown field") => CellError::UnknownKey {
                file: file.clone(),
                key: key.to_string(),
                line,
                suggestion: closest(key, known).map(str::to_string),
            },
            Some((key, _)) if message.starts_with("missing field") => CellError::MissingKey {
                file: file.clone(),
                key: key.to_string(),
                line,
            },
            _ => CellError::BadValue {
                file: file.clone(),
                line,
                message,
            },
        }
    })?;

    if !(raw.size.is_finite() && raw.size > 0.0) {
        return Err(CellError::BadSize {
            file,
            size: raw.size,
        });
    }
    match (&raw.pattern, &raw.pattern_image) {
        (Some(_), Some(_)) => return Err(CellError::BothPatterns { file }),
        (None, None) => return Err(CellError::NoPattern { file }),
        _ => {}
    }

    let mut materials = Vec::with_capacity(raw.materials.len());
    for (key, m) in &raw.materials {
        materials.push(material(&file, key, m)?);
    }

    let (cols, rows, pixels) = if let Some(pattern) = &raw.pattern {
        text_pattern(&file, pattern, &materials)?
    } else {
        let image = raw.pattern_image.as_deref().unwrap_or_default();
        image_pattern(&file, base_dir, image, &materials)?
    };

    let name = raw.name.unwrap_or_else(|| {
        Path::new(file_name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    Ok(CellDesc {
        name,
        size: raw.size,
        cols,
        rows,
        pixels,
        materials,
    })
}

/// Validates one material (keys are checked against the pattern kind later).
fn material(file: &str, key: &str, m: &RawMaterial) -> Result<Material, CellError> {
    let bad = |problem| CellError::InvalidMaterial {
        file: file.to_string(),
        key: key.to_string(),
        problem,
    };
    let c = match (m.stiffness, m.poisson, m.tensor) {
        (Some(_), _, Some(_)) => return Err(bad(MaterialProblem::BothStiffnessAndTensor)),
        (None, _, None) => return Err(bad(MaterialProblem::NeitherStiffnessNorTensor)),
        (None, Some(_), Some(_)) => return Err(bad(MaterialProblem::PoissonWithTensor)),
        (Some(_), None, None) => return Err(bad(MaterialProblem::MissingPoisson)),
        (Some(y), Some(nu), None) => {
            if !(y.is_finite() && y > 0.0) {
                return Err(bad(MaterialProblem::BadStiffness(y)));
            }
            // The isotropic membrane C is positive definite for -1 < ν < 1; the format asks
            // for ν < 1/2, the bound of the isotropic 3D solid a membrane is cut from.
            if !(nu > -1.0 && nu < 0.5) {
                return Err(bad(MaterialProblem::PoissonOutOfRange(nu)));
            }
            membrane::isotropic(y, nu)
        }
        (None, None, Some(t)) => {
            match crate::voigt::check_spd(&t) {
                Ok(()) => {}
                Err(SpdProblem::NotFinite) => return Err(bad(MaterialProblem::TensorNotFinite)),
                Err(SpdProblem::Asymmetric { row, col }) => {
                    let at = |i: usize, j: usize| t.get(i).and_then(|r| r.get(j)).copied();
                    return Err(bad(MaterialProblem::TensorNotSymmetric {
                        row,
                        col,
                        lower: at(row, col).unwrap_or(f64::NAN),
                        upper: at(col, row).unwrap_or(f64::NAN),
                    }));
                }
                Err(SpdProblem::NotPositiveDefinite) => {
                    return Err(bad(MaterialProblem::TensorNotPositiveDefinite))
                }
            }
            // is_spd accepts a relative 1e-9 asymmetry (decimal round-off in the file);
            // store the symmetric part so C is exactly symmetric downstream.
            let [[t00, t01, t02], [t10, t11, t12], [t20, t21, t22]] = t;
            let (s10, s20, s21) = (0.5 * (t10 + t01), 0.5 * (t20 + t02), 0.5 * (t21 + t12));
            [[t00, s10, s20], [s10, t11, s21], [s20, s21, t22]]
        }
    };
    if !(m.density.is_finite() && m.density > 0.0) {
        return Err(bad(MaterialProblem::BadDensity(m.density)));
    }
    let bending = m.bending.unwrap_or(DEFAULT_BENDING);
    if !(bending.is_finite() && bending >= 0.0) {
        return Err(bad(MaterialProblem::BadBending(bending)));
    }
    Ok(Material {
        key: key.to_string(),
        c,
        density: m.density,
        bending,
    })
}

type Pattern = (usize, usize, Vec<u32>);

fn text_pattern(
    file: &str,
    pattern: &[String],
    materials: &[Material],
) -> Result<Pattern, CellError> {
    let mut by_char = BTreeMap::new();
    for (index, m) in materials.iter().enumerate() {
        let mut chars = m.key.chars();
        match (chars.next(), chars.next()) {
            (Some(ch), None) => {
                by_char.insert(ch, index as u32);
            }
            _ => {
                return Err(CellError::BadMaterialKey {
                    file: file.to_string(),
                    key: m.key.clone(),
                    reason: "a text pattern's material keys must be single characters",
                })
            }
        }
    }
    let rows = pattern.len();
    let cols = pattern.first().map_or(0, |r| r.chars().count());
    if rows == 0 || cols == 0 {
        return Err(CellError::EmptyPattern {
            file: file.to_string(),
        });
    }
    let mut pixels = Vec::with_capacity(rows * cols);
    for (row, line) in pattern.iter().enumerate() {
        let len = line.chars().count();
        if len != cols {
            return Err(CellError::RaggedRow {
                file: file.to_string(),
                row,
                len,
                expected: cols,
            });
        }
        for (col, ch) in line.chars().enumerate() {
            match by_char.get(&ch) {
                Some(&index) => pixels.push(index),
                None => {
                    return Err(CellError::UnknownPatternChar {
                        file: file.to_string(),
                        row,
                        col,
                        ch,
                    })
                }
            }
        }
    }
    Ok((cols, rows, pixels))
}

/// `#rrggbb` (either case) as `0xrrggbb`.
fn parse_color(key: &str) -> Option<u32> {
    let hex = key.strip_prefix('#')?;
    if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(hex, 16).ok()
}

fn image_pattern(
    file: &str,
    base_dir: &Path,
    image: &str,
    materials: &[Material],
) -> Result<Pattern, CellError> {
    let mut by_color = BTreeMap::new();
    for (index, m) in materials.iter().enumerate() {
        let Some(color) = parse_color(&m.key) else {
            return Err(CellError::BadMaterialKey {
                file: file.to_string(),
                key: m.key.clone(),
                reason: "an image pattern's material keys must be colors \"#rrggbb\"",
            });
        };
        if by_color.insert(color, index as u32).is_some() {
            return Err(CellError::BadMaterialKey {
                file: file.to_string(),
                key: m.key.clone(),
                reason: "another key names the same color",
            });
        }
    }
    let image_err = |message: String| CellError::Image {
        file: file.to_string(),
        image: image.to_string(),
        message,
    };
    let path = base_dir.join(image);
    let reader = std::fs::File::open(&path)
        .map_err(|e| image_err(format!("cannot open {}: {e}", path.display())))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(reader));
    // Palette → RGB, 16 → 8 bits, sub-byte gray → 8 bits: every pixel becomes 8-bit samples.
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| image_err(e.to_string()))?;
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| image_err(e.to_string()))?;
    let (cols, rows) = (info.width as usize, info.height as usize);
    if rows == 0 || cols == 0 {
        return Err(CellError::EmptyPattern {
            file: file.to_string(),
        });
    }
    // Alpha is ignored: the pattern is the color only.
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => {
            return Err(image_err("palette was not expanded".to_string()));
        }
    };
    if info.bit_depth != png::BitDepth::Eight {
        return Err(image_err(format!(
            "unexpected bit depth {:?}",
            info.bit_depth
        )));
    }
    let mut pixels = Vec::with_capacity(rows * cols);
    // PNG scanlines run top to bottom, like pattern rows (row 0 = top).
    for row in 0..rows {
        let line = buf
            .get(row * info.line_size..(row + 1) * info.line_size)
            .ok_or_else(|| image_err("truncated image data".to_string()))?;
        for col in 0..cols {
            let px = line
                .get(col * channels..(col + 1) * channels)
                .ok_or_else(|| image_err("truncated image data".to_string()))?;
            // (`px` has `channels` bytes: RGB(A), or grey (and alpha))
            let (r, g, b) = match *px {
                [r, g, b, ..] => (r, g, b),
                [l, ..] => (l, l, l),
                [] => return Err(image_err("image without channels".to_string())),
            };
            let color = (u32::from(r) << 16) | (u32::from(g) << 8) | u32::from(b);
            match by_color.get(&color) {
                Some(&index) => pixels.push(index),
                None => {
                    return Err(CellError::UnknownPixelColor {
                        file: file.to_string(),
                        image: image.to_string(),
                        row,
                        col,
                        color: format!("#{color:06x}"),
                    })
                }
            }
        }
    }
    Ok((cols, rows, pixels))
}

/// The pixel mesh of a cell (periodic) or of a tiled sheet (not periodic), numbered as in
/// `docs/ARCHITECTURE.md`.
#[derive(Clone, Debug, PartialEq)]
pub struct MicroMesh {
    /// Squares along u (whole mesh: for a sheet, all tiles).
    pub nu: usize,
    /// Squares along v (whole mesh).
    pub nv: usize,
    /// Side of a square, metres.
    pub h: f64,
    /// True for a cell: nodes wrap, `nu * nv` nodes. False for a sheet: `(nu+1) * (nv+1)`.
    pub periodic: bool,
    /// Rest position `(u, v)` of each node, metres.
    pub nodes: Vec<[f64; 2]>,
    /// Counter-clockwise node triples.
    pub triangles: Vec<[u32; 3]>,
    /// Material index (into `CellDesc::materials`) of each triangle.
    pub tri_material: Vec<u32>,
    /// Unwrapped `(u, v)` of each triangle's corners: for a periodic cell, a corner whose node
    /// wrapped sits at `+width` / `+height` of the node's position, so every triangle has its
    /// true shape even where its node indices wrap.
    pub tri_corners: Vec<[[f64; 2]; 3]>,
}

/// Periodic mesh of a cell: `refine` splits every pixel into `refine × refine` squares
/// (`refine` 0 is taken as 1). Node `(i, j)` is `j*nu + i` at `(i h, j h)`; square `(i, j)`
/// gives triangles `2(j nu + i)` = `[ll, lr, ur]` and `+1` = `[ll, ur, ul]`, corners wrapped
/// modulo `nu`, `nv`.
pub fn mesh_cell(desc: &CellDesc, refine: usize) -> MicroMesh {
    let k = refine.max(1);
    let (nu, nv) = (desc.cols * k, desc.rows * k);
    // Coordinates as size * i / nu (not i * h) so a wrapped corner lands exactly on the width.
    let at = |i: usize| {
        if nu == 0 {
            0.0
        } else {
            desc.size * i as f64 / nu as f64
        }
    };
    let mut nodes = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            nodes.push([at(i), at(j)]);
        }
    }
    let id = |i: usize, j: usize| lattice::node(i % nu, j % nv, nu) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    let mut tri_material = Vec::with_capacity(2 * nu * nv);
    let mut tri_corners = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (ll, lr, ur, ul) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            let (pll, plr) = ([at(i), at(j)], [at(i + 1), at(j)]);
            let (pur, pul) = ([at(i + 1), at(j + 1)], [at(i), at(j + 1)]);
            let (row, col) = lattice::pixel_of_square(i, j, k, desc.rows);
            let material = desc.pixel(row, col);
            triangles.extend(lattice::square_triangles(ll, lr, ur, ul));
            tri_corners.push([pll, plr, pur]);
            tri_corners.push([pll, pur, pul]);
            tri_material.push(material);
            tri_material.push(material);
        }
    }
    MicroMesh {
        nu,
        nv,
        h: at(1),
        periodic: true,
        nodes,
        triangles,
        tri_material,
        tri_corners,
    }
}

/// Non-periodic sheet of `tiles_u × tiles_v` copies of the cell (0 taken as 1), for the fine
/// reference simulation. `nu`/`nv` of the result count the squares of the whole sheet; node
/// `(i, j)` is `j (nu+1) + i`; square `(i, j)` gives triangles `2(j nu + i) + {0, 1}` as in
/// [`mesh_cell`], with the material of the cell's pixel at `(i mod nu_cell, j mod nv_cell)`.
pub fn mesh_sheet(desc: &CellDesc, refine: usize, tiles_u: usize, tiles_v: usize) -> MicroMesh {
    let k = refine.max(1);
    let (cu, cv) = (desc.cols * k, desc.rows * k);
    let (nu, nv) = (cu * tiles_u.max(1), cv * tiles_v.max(1));
    let at = |i: usize| {
        if cu == 0 {
            0.0
        } else {
            desc.size * i as f64 / cu as f64
        }
    };
    let stride = nu + 1;
    let mut nodes = Vec::with_capacity(stride * (nv + 1));
    for j in 0..=nv {
        for i in 0..=nu {
            nodes.push([at(i), at(j)]);
        }
    }
    let id = |i: usize, j: usize| lattice::node(i, j, stride) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    let mut tri_material = Vec::with_capacity(2 * nu * nv);
    let mut tri_corners = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (ll, lr, ur, ul) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            let (pll, plr) = ([at(i), at(j)], [at(i + 1), at(j)]);
            let (pur, pul) = ([at(i + 1), at(j + 1)], [at(i), at(j + 1)]);
            let (row, col) = lattice::pixel_of_square(i % cu, j % cv, k, desc.rows);
            let material = desc.pixel(row, col);
            triangles.extend(lattice::square_triangles(ll, lr, ur, ul));
            tri_corners.push([pll, plr, pur]);
            tri_corners.push([pll, pur, pul]);
            tri_material.push(material);
            tri_material.push(material);
        }
    }
    MicroMesh {
        nu,
        nv,
        h: at(1),
        periodic: false,
        nodes,
        triangles,
        tri_material,
        tri_corners,
    }
}

/// `T C T` with `T` the Voigt map of a 90° counter-clockwise rotation.
///
/// Rotating the material by `Q = [[0, -1], [1, 0]]` means the new material under strain `ε'`
/// responds like the old one under `ε = Qᵀ ε' Q`, which is `ε11 = ε'22`, `ε22 = ε'11`,
/// `ε12 = -ε'12`: in Voigt form `e = T e'` with `T = [[0,1,0],[1,0,0],[0,0,-1]]` (engineering
/// shear keeps the sign rule). Stress transforms the same way (`T` is orthogonal and its own
/// inverse), so `C' = Tᵀ C T = T C T`: `C'11 = C22`, `C'22 = C11`, `C'33 = C33`,
/// `C'12 = C12`, `C'13 = -C23`, `C'23 = -C13`.
pub fn rotate_tensor90(c: &Voigt) -> Voigt {
    // r[i][j] = sign[i] sign[j] c[p[i]][p[j]] with p = [1, 0, 2], sign = [1, 1, -1]
    let [[c00, c01, c02], [c10, c11, c12], [c20, c21, c22]] = *c;
    [[c11, c10, -c12], [c01, c00, -c02], [-c21, -c20, c22]]
}

/// The cell rotated by 90° counter-clockwise: pattern and material tensors. The new cell is the
/// old one's height wide (`size` becomes `height()`); old pixel `(r, c)` lands at
/// `(row = cols-1-c, col = r)`.
pub fn rotate90(desc: &CellDesc) -> CellDesc {
    let (rows, cols) = (desc.cols, desc.rows);
    let mut pixels = vec![0u32; rows * cols];
    for r in 0..desc.rows {
        for c in 0..desc.cols {
            // (always < rows × cols)
            if let Some(p) = pixels.get_mut((desc.cols - 1 - c) * cols + r) {
                *p = desc.pixel(r, c);
            }
        }
    }
    let materials = desc
        .materials
        .iter()
        .map(|m| Material {
            c: rotate_tensor90(&m.c),
            ..m.clone()
        })
        .collect();
    CellDesc {
        name: format!("{}_rot90", desc.name),
        size: desc.height(),
        cols,
        rows,
        pixels,
        materials,
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the numbering formulas
mod tests {
    use super::*;

    const GOOD: &str = r##"
name = "two"
size = 0.02
pattern = ["#..", "..#"]
[materials."#"]
stiffness = 1000
poisson = 0.3
density = 0.2
[materials."."]
tensor = [[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]
density = 0.1
bending = 2e-6
"##;

    fn parse_str(text: &str) -> Result<CellDesc, CellError> {
        parse(text, "dir/cell.toml", Path::new("dir"))
    }

    /// GOOD with `from` replaced by `to` (which must occur).
    fn variant(from: &str, to: &str) -> Result<CellDesc, CellError> {
        assert!(GOOD.contains(from), "{from}");
        parse_str(&GOOD.replacen(from, to, 1))
    }

    fn invalid(from: &str, to: &str) -> (String, MaterialProblem) {
        match variant(from, to) {
            Err(CellError::InvalidMaterial { key, problem, .. }) => (key, problem),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn parses_a_good_file() {
        let d = parse_str(GOOD).unwrap();
        assert_eq!(d.name, "two");
        assert_eq!((d.cols, d.rows), (3, 2));
        assert!((d.width() - 0.02).abs() < 1e-15);
        assert!((d.height() - 0.02 * 2.0 / 3.0).abs() < 1e-15);
        // materials sorted by key: "#" < "."
        assert_eq!(d.materials[0].key, "#");
        assert_eq!(d.materials[1].key, ".");
        assert_eq!(d.pixels, vec![0, 1, 1, 1, 1, 0]);
        assert_eq!(d.pixel(0, 0), 0);
        assert_eq!(d.pixel(1, 2), 0);
        assert_eq!(d.pixel(2, 0), u32::MAX);
        assert_eq!(d.materials[0].c, membrane::isotropic(1000.0, 0.3));
        assert_eq!(d.materials[0].bending, DEFAULT_BENDING);
        assert_eq!(d.materials[1].bending, 2e-6);
        assert_eq!(d.materials[1].c[0][1], 40.0);
        // default name is the file stem
        let d = variant("name = \"two\"", "").unwrap();
        assert_eq!(d.name, "cell");
    }

    #[test]
    fn syntax_errors() {
        match variant("size = 0.02", "size = = 0.02") {
            Err(CellError::Syntax { line, .. }) => assert_eq!(line, Some(3)),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn unknown_and_missing_keys() {
        match variant("size = 0.02", "size = 0.02\nsiz = 1") {
            Err(e @ CellError::UnknownKey { .. }) => {
                assert!(e.to_string().contains("`siz`"), "{e}");
                assert!(e.to_string().contains("dir/cell.toml"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        match variant("density = 0.2", "density = 0.2\nstiffnes = 3") {
            Err(e @ CellError::UnknownKey { .. }) => {
                assert!(e.to_string().ends_with("did you mean `stiffness`?"), "{e}");
                let CellError::UnknownKey {
                    key, suggestion, ..
                } = e
                else {
                    unreachable!()
                };
                assert_eq!(
                    (key.as_str(), suggestion.as_deref()),
                    ("stiffnes", Some("stiffness"))
                );
            }
            other => panic!("{other:?}"),
        }
        // top level, and one edit at most for short keys: `siz` is `size`, `zzz` nothing
        for (typo, want) in [
            ("pattern_imag", Some("pattern_image")),
            ("nmae", Some("name")),
            ("siz", Some("size")),
            ("zzz", None),
        ] {
            match variant("size = 0.02", &format!("size = 0.02\n{typo} = 1")) {
                Err(CellError::UnknownKey { suggestion, .. }) => {
                    assert_eq!(suggestion.as_deref(), want, "{typo}")
                }
                other => panic!("{other:?}"),
            }
        }
        match variant("size = 0.02", "") {
            Err(CellError::MissingKey { key, .. }) => assert_eq!(key, "size"),
            other => panic!("{other:?}"),
        }
        match variant("density = 0.1", "") {
            Err(CellError::MissingKey { key, .. }) => assert_eq!(key, "density"),
            other => panic!("{other:?}"),
        }
        match variant("size = 0.02", "size = \"big\"") {
            Err(CellError::BadValue { line, .. }) => assert_eq!(line, Some(3)),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            variant("[0.0, 0.0, 30.0]]", "]"),
            Err(CellError::BadValue { .. })
        ));
    }

    #[test]
    fn pattern_errors() {
        match variant("\"..#\"", "\".x#\"") {
            Err(e @ CellError::UnknownPatternChar { .. }) => {
                assert_eq!(
                    e,
                    CellError::UnknownPatternChar {
                        file: "dir/cell.toml".into(),
                        row: 1,
                        col: 1,
                        ch: 'x'
                    }
                );
                assert!(e.to_string().contains("row 1, column 1"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        match variant("\"..#\"", "\"..#.\"") {
            Err(CellError::RaggedRow {
                row, len, expected, ..
            }) => assert_eq!((row, len, expected), (1, 4, 3)),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            variant("[\"#..\", \"..#\"]", "[]"),
            Err(CellError::EmptyPattern { .. })
        ));
        assert!(matches!(
            variant("[\"#..\", \"..#\"]", "[\"\"]"),
            Err(CellError::EmptyPattern { .. })
        ));
        assert!(matches!(
            variant("pattern = [\"#..\", \"..#\"]", ""),
            Err(CellError::NoPattern { .. })
        ));
        assert!(matches!(
            variant("size = 0.02", "size = 0.02\npattern_image = \"a.png\""),
            Err(CellError::BothPatterns { .. })
        ));
        match variant("[materials.\".\"]", "[materials.\"..\"]") {
            Err(CellError::BadMaterialKey { key, .. }) => assert_eq!(key, ".."),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn size_errors() {
        for bad in ["0.0", "-1.0", "nan", "inf"] {
            match variant("size = 0.02", &format!("size = {bad}")) {
                Err(CellError::BadSize { .. }) => {}
                other => panic!("{bad}: {other:?}"),
            }
        }
    }

    #[test]
    fn material_errors() {
        use MaterialProblem::*;
        let (key, p) = invalid(
            "stiffness = 1000",
            "stiffness = 1000\ntensor = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]",
        );
        assert_eq!((key.as_str(), p), ("#", BothStiffnessAndTensor));
        let (key, p) = invalid(
            "tensor = [[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]",
            "",
        );
        assert_eq!((key.as_str(), p), (".", NeitherStiffnessNorTensor));
        assert_eq!(invalid("poisson = 0.3", "").1, MissingPoisson);
        assert_eq!(
            invalid("density = 0.1", "density = 0.1\npoisson = 0.2").1,
            PoissonWithTensor
        );
        for bad in ["0.5", "-1.0", "0.7", "nan"] {
            match invalid("poisson = 0.3", &format!("poisson = {bad}")).1 {
                PoissonOutOfRange(_) => {}
                p => panic!("{bad}: {p:?}"),
            }
        }
        for bad in ["0", "-5", "nan", "inf"] {
            match invalid("stiffness = 1000", &format!("stiffness = {bad}")).1 {
                BadStiffness(_) => {}
                p => panic!("{bad}: {p:?}"),
            }
        }
        for bad in ["0", "-0.2", "nan", "inf"] {
            match invalid("density = 0.2", &format!("density = {bad}")).1 {
                BadDensity(_) => {}
                p => panic!("{bad}: {p:?}"),
            }
        }
        for bad in ["-1e-6", "nan", "inf"] {
            match invalid("bending = 2e-6", &format!("bending = {bad}")).1 {
                BadBending(_) => {}
                p => panic!("{bad}: {p:?}"),
            }
        }
        // zero bending is allowed
        assert!(variant("bending = 2e-6", "bending = 0.0").is_ok());
        // indefinite, and asymmetric, tensors: told apart
        let spd = "[[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]";
        for t in [
            "[[300.0, 400.0, 0.0], [400.0, 90.0, 0.0], [0.0, 0.0, 30.0]]",
            "[[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, -30.0]]",
        ] {
            let (key, p) = invalid(spd, t);
            assert_eq!((key.as_str(), p), (".", TensorNotPositiveDefinite));
        }
        let (_, p) = invalid(
            spd,
            "[[300.0, 40.0, 0.0], [41.0, 90.0, 0.0], [0.0, 0.0, 30.0]]",
        );
        assert_eq!(
            p,
            TensorNotSymmetric {
                row: 1,
                col: 0,
                lower: 41.0,
                upper: 40.0
            }
        );
        assert!(p.to_string().contains("not symmetric"), "{p}");
        // asymmetric and indefinite: the asymmetry is named first
        let (_, p) = invalid(
            spd,
            "[[300.0, 400.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]",
        );
        assert!(
            matches!(p, TensorNotSymmetric { row: 1, col: 0, .. }),
            "{p:?}"
        );
        let e = variant("poisson = 0.3", "poisson = 0.6").unwrap_err();
        assert!(e.to_string().contains("\"#\""), "{e}");
        // an unused invalid material is still an error; an unused valid one is fine, and named
        let d = variant(
            "[materials.\".\"]",
            "[materials.\"x\"]\nstiffness = 1.0\npoisson = 0.0\ndensity = 1.0\n[materials.\".\"]",
        )
        .unwrap();
        assert_eq!(d.unused_materials(), ["x"]);
        assert!(parse_str(GOOD).unwrap().unused_materials().is_empty());
    }

    fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) {
        let file = std::fs::File::create(path).unwrap();
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(rgb).unwrap();
    }

    #[test]
    fn image_patterns() {
        let dir = std::env::temp_dir().join(format!("weft-cell-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // 3 wide, 2 tall: top row red, green, red; bottom row green, green, blue
        let (r, g, b) = ([255u8, 0, 0], [0u8, 255, 0], [0u8, 0, 255]);
        let data: Vec<u8> = [r, g, r, g, g, b].concat();
        write_png(&dir.join("p.png"), 3, 2, &data);
        let mats = "[materials.\"#FF0000\"]\nstiffness = 1.0\npoisson = 0.1\ndensity = 1.0\n\
                    [materials.\"#00ff00\"]\nstiffness = 2.0\npoisson = 0.1\ndensity = 1.0\n";
        let text = format!(
            "size = 1.0\npattern_image = \"p.png\"\n{mats}[materials.\"#0000ff\"]\nstiffness = 3.0\npoisson = 0.1\ndensity = 1.0\n"
        );
        let d = parse(&text, "img.toml", &dir).unwrap();
        assert_eq!((d.cols, d.rows), (3, 2));
        let keys: Vec<_> = d.materials.iter().map(|m| m.key.as_str()).collect();
        assert_eq!(keys, ["#0000ff", "#00ff00", "#FF0000"]);
        assert_eq!(d.pixels, vec![2, 1, 2, 1, 1, 0]);
        // a color without material
        let text = format!("size = 1.0\npattern_image = \"p.png\"\n{mats}");
        match parse(&text, "img.toml", &dir) {
            Err(CellError::UnknownPixelColor {
                row, col, color, ..
            }) => assert_eq!((row, col, color.as_str()), (1, 2, "#0000ff")),
            other => panic!("{other:?}"),
        }
        // single-char key in image mode, duplicate color, missing file, not a PNG
        let text = format!(
            "size = 1.0\npattern_image = \"p.png\"\n{mats}[materials.\"b\"]\nstiffness = 3.0\npoisson = 0.1\ndensity = 1.0\n"
        );
        assert!(matches!(
            parse(&text, "img.toml", &dir),
            Err(CellError::BadMaterialKey { .. })
        ));
        let text = format!(
            "size = 1.0\npattern_image = \"p.png\"\n{mats}[materials.\"#ff0000\"]\nstiffness = 3.0\npoisson = 0.1\ndensity = 1.0\n"
        );
        assert!(matches!(
            parse(&text, "img.toml", &dir),
            Err(CellError::BadMaterialKey { .. })
        ));
        let text = format!("size = 1.0\npattern_image = \"nope.png\"\n{mats}");
        assert!(matches!(
            parse(&text, "img.toml", &dir),
            Err(CellError::Image { .. })
        ));
        std::fs::write(dir.join("bad.png"), b"not a png").unwrap();
        let text = format!("size = 1.0\npattern_image = \"bad.png\"\n{mats}");
        assert!(matches!(
            parse(&text, "img.toml", &dir),
            Err(CellError::Image { .. })
        ));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn load_reports_missing_file() {
        match load(Path::new("/nonexistent/weft/cell.toml")) {
            Err(e @ CellError::Io { .. }) => assert!(e.to_string().contains("cell.toml")),
            other => panic!("{other:?}"),
        }
    }

    fn desc(cols: usize, rows: usize) -> CellDesc {
        // pixel (r, c) has material r * cols + c: every pixel distinct
        CellDesc {
            name: "t".into(),
            size: 0.3,
            cols,
            rows,
            pixels: (0..(rows * cols) as u32).collect(),
            materials: Vec::new(),
        }
    }

    fn signed_area(p: [[f64; 2]; 3]) -> f64 {
        0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
            - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
    }

    #[test]
    fn periodic_numbering() {
        let d = desc(3, 2);
        for k in [1usize, 2, 3] {
            let m = mesh_cell(&d, k);
            let (nu, nv) = (3 * k, 2 * k);
            assert_eq!((m.nu, m.nv), (nu, nv));
            assert!(m.periodic);
            assert_eq!(m.nodes.len(), nu * nv);
            assert_eq!(m.triangles.len(), 2 * nu * nv);
            assert!((m.h - 0.1 / k as f64).abs() < 1e-15);
            for j in 0..nv {
                for i in 0..nu {
                    let n = m.nodes[j * nu + i];
                    assert!((n[0] - i as f64 * m.h).abs() < 1e-14);
                    assert!((n[1] - j as f64 * m.h).abs() < 1e-14);
                    let t = 2 * (j * nu + i);
                    let w = |a: usize, b: usize| ((b % nv) * nu + a % nu) as u32;
                    let (ll, lr, ur, ul) = (w(i, j), w(i + 1, j), w(i + 1, j + 1), w(i, j + 1));
                    assert_eq!(m.triangles[t], [ll, lr, ur]);
                    assert_eq!(m.triangles[t + 1], [ll, ur, ul]);
                    // row flip: square row j is pattern row rows-1-j/k
                    let mat = ((1 - j / k) * 3 + i / k) as u32;
                    assert_eq!(m.tri_material[t], mat);
                    assert_eq!(m.tri_material[t + 1], mat);
                    // unwrapped corners: node position + width/height where wrapped
                    for tt in [t, t + 1] {
                        let c = m.tri_corners[tt];
                        assert!((signed_area(c) - 0.5 * m.h * m.h).abs() < 1e-15);
                        for a in 0..3 {
                            let p = m.nodes[m.triangles[tt][a] as usize];
                            let du = c[a][0] - p[0];
                            let dv = c[a][1] - p[1];
                            assert!(du.abs() < 1e-14 || (du - d.width()).abs() < 1e-14);
                            assert!(dv.abs() < 1e-14 || (dv - d.height()).abs() < 1e-14);
                        }
                    }
                }
            }
            // the top-right square wraps to node 0 exactly at (width, height)
            let t = 2 * (nu * nv - 1);
            assert_eq!(m.triangles[t][2], 0);
            assert_eq!(m.tri_corners[t][2], [d.width(), d.height()]);
        }
        // explicit refine-1 spot checks: 3×2 cell, square (2, 1) is top right
        let m = mesh_cell(&d, 1);
        assert_eq!(m.triangles[2 * 5], [5, 3, 0]);
        assert_eq!(m.triangles[2 * 5 + 1], [5, 0, 2]);
        assert_eq!(m.tri_material[2 * 5], 2); // pattern row 0, col 2
        assert_eq!(m.tri_material[0], 3); // square (0,0): pattern row 1, col 0
                                          // refine 0 is refine 1
        assert_eq!(mesh_cell(&d, 0), m);
    }

    #[test]
    fn sheet_numbering() {
        let d = desc(3, 2);
        let m = mesh_sheet(&d, 2, 2, 3);
        let (nu, nv) = (12, 12);
        assert_eq!((m.nu, m.nv), (nu, nv));
        assert!(!m.periodic);
        assert_eq!(m.nodes.len(), (nu + 1) * (nv + 1));
        assert_eq!(m.triangles.len(), 2 * nu * nv);
        for j in 0..nv {
            for i in 0..nu {
                let t = 2 * (j * nu + i);
                let s = nu + 1;
                let ll = (j * s + i) as u32;
                assert_eq!(m.triangles[t], [ll, ll + 1, ll + 1 + s as u32]);
                assert_eq!(m.triangles[t + 1], [ll, ll + 1 + s as u32, ll + s as u32]);
                let mat = ((1 - (j % 4) / 2) * 3 + (i % 6) / 2) as u32;
                assert_eq!(m.tri_material[t], mat);
                for a in 0..3 {
                    assert_eq!(m.tri_corners[t][a], m.nodes[m.triangles[t][a] as usize]);
                }
            }
        }
        let last = m.nodes[m.nodes.len() - 1];
        assert!((last[0] - 2.0 * d.width()).abs() < 1e-14);
        assert!((last[1] - 3.0 * d.height()).abs() < 1e-14);
    }

    #[test]
    fn rotate90_pattern_and_tensor() {
        let mut d = desc(3, 2);
        d.materials = vec![Material {
            key: "a".into(),
            c: [[300.0, 40.0, 7.0], [40.0, 90.0, -5.0], [7.0, -5.0, 30.0]],
            density: 1.0,
            bending: 0.0,
        }];
        let r = rotate90(&d);
        assert_eq!((r.cols, r.rows), (2, 3));
        assert!((r.width() - d.height()).abs() < 1e-15);
        assert!((r.height() - d.width()).abs() < 1e-15);
        // top-right pixel of the original (0, 2) goes to the top-left (0, 0);
        // top-left (0, 0) goes to the bottom-left (2, 0).
        assert_eq!(r.pixel(0, 0), d.pixel(0, 2));
        assert_eq!(r.pixel(2, 0), d.pixel(0, 0));
        assert_eq!(r.pixel(2, 1), d.pixel(1, 0));
        // the tensor under strain rotated with it stores the same energy:
        // e' = T^-1 e with e the strain the old material sees.
        let c = d.materials[0].c;
        let cr = r.materials[0].c;
        // uniaxial strain along u in the old frame = along v in the new frame
        assert_eq!(cr[1][1], c[0][0]);
        assert_eq!(cr[0][0], c[1][1]);
        assert_eq!(cr[0][2], -c[1][2]);
        assert_eq!(cr[1][2], -c[0][2]);
        // four rotations are the identity
        let r4 = rotate90(&rotate90(&rotate90(&r)));
        assert_eq!(r4.pixels, d.pixels);
        assert_eq!(r4.materials, d.materials);
        assert!((r4.size - d.size).abs() < 1e-15);
    }

    #[test]
    fn rotated_tensor_matches_explicit_strain_rotation() {
        // Independent check of the sign rule: rotate a strain tensor by Q explicitly.
        let c = [[300.0, 40.0, 7.0], [40.0, 90.0, -5.0], [7.0, -5.0, 30.0]];
        let cr = rotate_tensor90(&c);
        let q = [[0.0, -1.0], [1.0, 0.0]];
        for e_new in [
            [0.013, -0.004, 0.021],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.3, 1.0, -0.2],
        ] {
            // e_new: strain applied to the rotated material
            let eps_new = [[e_new[0], 0.5 * e_new[2]], [0.5 * e_new[2], e_new[1]]];
            // eps_old = Q^T eps_new Q
            let mut eps_old = [[0.0; 2]; 2];
            for i in 0..2 {
                for j in 0..2 {
                    for a in 0..2 {
                        for b in 0..2 {
                            eps_old[i][j] += q[a][i] * eps_new[a][b] * q[b][j];
                        }
                    }
                }
            }
            let e_old = [eps_old[0][0], eps_old[1][1], 2.0 * eps_old[0][1]];
            let energy = |c: &Voigt, e: [f64; 3]| -> f64 {
                let s = membrane::stress(c, e);
                s[0] * e[0] + s[1] * e[1] + s[2] * e[2]
            };
            assert!((energy(&cr, e_new) - energy(&c, e_old)).abs() < 1e-9);
        }
    }
}
