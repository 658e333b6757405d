//! A run-time typed message laid out around sequences of numbers that are
//! filled where they lie: the layout a loan of a run-time type needs. The
//! caller gives the length of each such sequence; [`InPlaceLayout`] says
//! where its elements lie in the encoded message, and writes every other
//! byte (header, counts, padding, the other fields) around them, leaving
//! theirs as the buffer holds them.

use std::fmt;
use std::ops::Range;

use super::codec::{encode_struct, struct_end, Holes};
use super::model::DynamicType;
use super::structs::{Check, Element};
use super::value::Message;
use crate::describe::Container;
use crate::encode::Writer;
use crate::endian::{Endianness, LittleEndian};
use crate::error::EncodeError;
use crate::HEADER_LEN;

/// A message of a [`DynamicType`] laid out with some of its sequences of
/// numbers left for the caller to fill in place: the exact size, and where
/// each of those sequences' elements lies. Made by
/// [`DynamicType::lay_out_in_place`]; [`write_around`](Self::write_around)
/// writes the rest of the message.
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, Value};
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_cdr::RosMessage;
///
/// let ty = DynamicType::from_description(&Image::full_description())?;
/// let mut image = ty.default_message();
/// image.set("encoding", Value::String("mono8".into()))?;
/// image.set("width", Value::U32(4))?;
/// image.set("height", Value::U32(2))?;
/// image.set("step", Value::U32(4))?;
///
/// // Eight bytes of `data`, written where they lie.
/// let layout = ty.lay_out_in_place(&image, &[(&["data"], 8)])?;
/// let mut buffer = vec![0u8; layout.size()];
/// let data = layout.arrays()[0].range();
/// buffer[data].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
/// layout.write_around(&image, &mut buffer)?;
///
/// // The same bytes as the whole message encoded.
/// image.set("data", Value::U8s(vec![1, 2, 3, 4, 5, 6, 7, 8].into()))?;
/// assert_eq!(buffer, shm_cdr::to_vec(&image)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct InPlaceLayout {
    ty: DynamicType,
    size: usize,
    arrays: Vec<InPlaceArray>,
}

/// One sequence of numbers of an [`InPlaceLayout`], filled in place.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InPlaceArray {
    path: Vec<String>,
    slot: usize,
    element: Element,
    len: usize,
    range: Range<usize>,
}

impl InPlaceArray {
    /// The field's path (the names of the messages nested by value that
    /// hold it, then its own).
    pub fn path(&self) -> &[String] {
        &self.path
    }

    /// The kind of its elements.
    pub fn element(&self) -> Element {
        self.element
    }

    /// Its number of elements.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it has no elements.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Where its elements lie in the encoded message (header included):
    /// `len` elements of the element's size, aligned to it from the body's
    /// start (so the body's alignment decides whether they are aligned in
    /// memory), in little-endian order.
    pub fn range(&self) -> Range<usize> {
        self.range.clone()
    }
}

/// Why a message cannot be laid out in place, or written around its
/// layout.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum InPlaceError {
    /// A path names no sequence of numbers that can be filled in place.
    Field {
        /// The message type.
        type_name: String,
        /// The path, its names joined by dots.
        field: String,
        /// What is wrong, and what to do instead.
        reason: String,
    },
    /// The message is of another type than the layout's.
    OtherType {
        /// The layout's type.
        expected: String,
        /// The message's.
        found: String,
    },
    /// The message no longer lies as laid out: a string or sequence before
    /// an array filled in place changed length since.
    Moved {
        /// The first array that moved, its names joined by dots (empty when
        /// only the size changed).
        field: String,
    },
    /// Writing failed (a buffer too small, a bound exceeded).
    Encode(EncodeError),
}

impl fmt::Display for InPlaceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Field {
                type_name,
                field,
                reason,
            } => write!(f, "{type_name}.{field}: {reason}"),
            Self::OtherType { expected, found } => write!(
                f,
                "the layout is of {expected}, the message of {found}: write a message of the \
                 layout's type"
            ),
            Self::Moved { field } if field.is_empty() => write!(
                f,
                "the message's size changed since it was laid out: keep every string and \
                 sequence at the length it had, or lay it out again"
            ),
            Self::Moved { field } => write!(
                f,
                "{field} no longer lies where it was laid out: a string or sequence before it \
                 changed length; keep them at the length they had, or lay it out again"
            ),
            Self::Encode(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for InPlaceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Encode(e) => Some(e),
            _ => None,
        }
    }
}

impl From<EncodeError> for InPlaceError {
    fn from(e: EncodeError) -> Self {
        Self::Encode(e)
    }
}

/// The holes of a layout: each array's slot and length, and where sizing
/// or writing found its elements (body positions).
struct Found<'l> {
    arrays: &'l [InPlaceArray],
    at: Vec<Option<Range<usize>>>,
}

impl Holes for Found<'_> {
    const ANY: bool = true;

    fn len(&self, slot: usize) -> Option<usize> {
        self.arrays.iter().find(|a| a.slot == slot).map(|a| a.len)
    }

    fn lies(&mut self, slot: usize, range: Range<usize>) {
        if let Some(i) = self.arrays.iter().position(|a| a.slot == slot) {
            if let Some(at) = self.at.get_mut(i) {
                *at = Some(range);
            }
        }
    }
}

impl<'l> Found<'l> {
    fn new(arrays: &'l [InPlaceArray]) -> Self {
        Self {
            arrays,
            at: vec![None; arrays.len()],
        }
    }
}

impl DynamicType {
    /// Lay `message` (of this type) out with the sequences of numbers at
    /// `arrays` (each a path: the names of the messages nested by value that
    /// hold it, then its own) holding the given number of elements, their
    /// bytes left for the caller to fill where they lie. Their values in
    /// `message` are not read.
    ///
    /// A path must name a sequence (bounded or not) of numbers or bytes
    /// (not bools, whose bytes must be 0 or 1), in the message or in one it
    /// nests by value; not in an element of a sequence of messages, whose
    /// count is the message's to change. A fixed-size array is set as a
    /// value instead.
    pub fn lay_out_in_place(
        &self,
        message: &Message<'_>,
        arrays: &[(&[&str], usize)],
    ) -> Result<InPlaceLayout, InPlaceError> {
        self.check_of(message)?;
        let mut laid: Vec<InPlaceArray> = Vec::with_capacity(arrays.len());
        for &(path, len) in arrays {
            let (slot, element) = self.in_place_slot(path, len)?;
            if laid.iter().any(|a| a.slot == slot) {
                return Err(self.field_error(path, "is given twice: give each array once"));
            }
            laid.push(InPlaceArray {
                path: path.iter().map(|s| (*s).to_owned()).collect(),
                slot,
                element,
                len,
                range: 0..0,
            });
        }
        let mut found = Found::new(&laid);
        let end = struct_end(self, 0, &message.slots, 0, 0, &mut found);
        let at = found.at;
        for (array, at) in laid.iter_mut().zip(at) {
            // Every hole is a step of the root's plan or of one it nests by
            // value (`in_place_slot` walked only those): sizing visits it.
            let at = at.unwrap_or(0..0);
            array.range = at.start + HEADER_LEN..at.end + HEADER_LEN;
        }
        Ok(InPlaceLayout {
            ty: self.clone(),
            size: HEADER_LEN + end,
            arrays: laid,
        })
    }

    fn check_of(&self, message: &Message<'_>) -> Result<(), InPlaceError> {
        if message.is_of(self) && message.index == 0 {
            Ok(())
        } else {
            Err(InPlaceError::OtherType {
                expected: self.name().to_owned(),
                found: message.type_name().to_owned(),
            })
        }
    }

    fn field_error(&self, path: &[&str], reason: &str) -> InPlaceError {
        InPlaceError::Field {
            type_name: self.name().to_owned(),
            field: path.join("."),
            reason: reason.to_owned(),
        }
    }

    /// The absolute slot and element of the sequence of numbers at `path`,
    /// checked to hold `len` elements.
    fn in_place_slot(&self, path: &[&str], len: usize) -> Result<(usize, Element), InPlaceError> {
        let (Some((last, nesting)), mut index, mut base) = (path.split_last(), 0usize, 0usize)
        else {
            return Err(self.field_error(path, "is empty: name a field"));
        };
        let field_of = |index: usize, name: &str| {
            let def = self.inner.structs.get(index)?;
            let i = def.field_index(name)?;
            let check = *self.inner.checks.get(index)?.get(i)?;
            let offset = *self.inner.plans.get(index)?.offsets.get(i)?;
            Some((check, offset))
        };
        let no_field = |index: usize| {
            let def = self.inner.structs.get(index);
            let names: Vec<&str> = def
                .map(|d| d.fields.iter().map(|f| f.name.as_str()).collect())
                .unwrap_or_default();
            format!(
                "{} has no such field (its fields: {})",
                def.map_or("the message", |d| d.name.as_str()),
                names.join(", ")
            )
        };
        for name in nesting {
            let Some((check, offset)) = field_of(index, name) else {
                return Err(self.field_error(path, &no_field(index)));
            };
            match check {
                Check::Message { index: nested, .. } => {
                    index = nested;
                    base += offset;
                }
                Check::Many {
                    element: Element::Message(_),
                    ..
                } => {
                    return Err(self.field_error(
                        path,
                        "lies in an element of a sequence of messages: only arrays of the \
                         message and of the messages it nests by value are filled in place",
                    ))
                }
                _ => {
                    return Err(self.field_error(
                        path,
                        &format!("{name} is not a message: name a field of a nested message"),
                    ))
                }
            }
        }
        let Some((check, offset)) = field_of(index, last) else {
            return Err(self.field_error(path, &no_field(index)));
        };
        match check {
            Check::Many {
                element,
                container: Container::Sequence,
                ..
            } if element.is_number() => Ok((base + offset, element)),
            Check::Many {
                element,
                container: Container::BoundedSequence(bound),
                ..
            } if element.is_number() => {
                if len > bound {
                    Err(self
                        .field_error(path, &format!("holds at most {bound} elements, not {len}")))
                } else {
                    Ok((base + offset, element))
                }
            }
            Check::Many {
                element,
                container: Container::Array(n),
                ..
            } if element.is_number() => Err(self.field_error(
                path,
                &format!(
                    "is a fixed-size array of {n}: set it as a value; sequences are filled in \
                     place"
                ),
            )),
            _ => Err(self.field_error(
                path,
                "is not a sequence of numbers or bytes: set it as a value",
            )),
        }
    }
}

impl InPlaceLayout {
    /// The message's encoded size in bytes, header included.
    pub fn size(&self) -> usize {
        self.size
    }

    /// The sequences filled in place, in the order they were given.
    pub fn arrays(&self) -> &[InPlaceArray] {
        &self.arrays
    }

    /// The layout's type.
    pub fn ty(&self) -> &DynamicType {
        &self.ty
    }

    /// Write `message` as little-endian CDR into the first
    /// [`size`](Self::size) bytes of `buf`: every byte but the elements of
    /// the arrays filled in place, which keep what `buf` holds there.
    /// Returns the size. The message must still lie as laid out (its
    /// strings and sequences before each array at the lengths they had);
    /// its fixed-size fields, and everything after the last array, may have
    /// changed. Nothing is written unless it does.
    pub fn write_around(
        &self,
        message: &Message<'_>,
        buf: &mut [u8],
    ) -> Result<usize, InPlaceError> {
        self.ty.check_of(message)?;
        // Sized first: a message that moved writes nothing over the arrays.
        let mut found = Found::new(&self.arrays);
        let end = struct_end(&self.ty, 0, &message.slots, 0, 0, &mut found);
        self.check_same(&found)?;
        if HEADER_LEN + end != self.size {
            return Err(InPlaceError::Moved {
                field: String::new(),
            });
        }
        let Some((header, body)) = buf.split_first_chunk_mut::<HEADER_LEN>() else {
            return Err(
                EncodeError::new(crate::error::EncodeErrorKind::BufferTooSmall {
                    needed: self.size,
                    available: buf.len(),
                })
                .into(),
            );
        };
        let available = HEADER_LEN + body.len();
        let Some(body) = body.get_mut(..end) else {
            return Err(
                EncodeError::new(crate::error::EncodeErrorKind::BufferTooSmall {
                    needed: self.size,
                    available,
                })
                .into(),
            );
        };
        *header = Endianness::Little.header();
        let mut w = Writer::<LittleEndian>::new(body);
        let mut found = Found::new(&self.arrays);
        encode_struct(&mut w, &self.ty, 0, &message.slots, 0, &mut found)?;
        self.check_same(&found)?;
        Ok(self.size)
    }

    /// Whether each array was found where it was laid out.
    fn check_same(&self, found: &Found<'_>) -> Result<(), InPlaceError> {
        for (array, at) in self.arrays.iter().zip(&found.at) {
            let expected = array.range.start - HEADER_LEN..array.range.end - HEADER_LEN;
            if at.as_ref() != Some(&expected) {
                return Err(InPlaceError::Moved {
                    field: array.path.join("."),
                });
            }
        }
        Ok(())
    }
}

#[cfg(all(test, feature = "sensor_msgs"))]
mod tests {
    use super::InPlaceError;
    use crate::dynamic::{DynamicType, Numbers, Value};
    use crate::msgs::sensor_msgs::{LaserScan, PointCloud2};
    use crate::RosMessage;

    #[test]
    fn an_image_of_every_length_lies_as_the_whole_message_encodes() {
        let ty =
            DynamicType::from_description(&crate::msgs::sensor_msgs::Image::full_description())
                .unwrap();
        for frame in ["", "c", "camera", "camera_opt"] {
            for n in [0usize, 1, 3, 8, 1000] {
                let mut image = ty.default_message();
                image.set("encoding", Value::String("rgb8".into())).unwrap();
                let mut header = image.message("header").unwrap().to_message();
                header.set("frame_id", Value::String(frame.into())).unwrap();
                image
                    .set("header", Value::Message(Box::new(header)))
                    .unwrap();
                let layout = ty.lay_out_in_place(&image, &[(&["data"], n)]).unwrap();
                let data: Vec<u8> = (0..n).map(|i| (i * 7 + 1) as u8).collect();
                // Stale bytes everywhere: the layout writes all but the array.
                let mut buffer = vec![0xa5u8; layout.size()];
                buffer[layout.arrays()[0].range()].copy_from_slice(&data);
                assert_eq!(layout.write_around(&image, &mut buffer), Ok(layout.size()));
                image.set("data", Value::U8s(data.into())).unwrap();
                assert_eq!(buffer, crate::to_vec(&image).unwrap(), "{frame:?}, {n}");
            }
        }
    }

    #[test]
    fn two_float_sequences_are_aligned_as_encoded() {
        let ty = DynamicType::from_description(&LaserScan::full_description()).unwrap();
        let mut scan = ty.default_message();
        scan.set("range_max", Value::F32(30.0)).unwrap();
        let layout = ty
            .lay_out_in_place(&scan, &[(&["ranges"], 5), (&["intensities"], 3)])
            .unwrap();
        let ranges = [1.0f32, 2.0, 3.5, 4.0, 5.25];
        let intensities = [7.0f32, 8.0, 9.0];
        let mut buffer = vec![0xffu8; layout.size()];
        for (array, values) in layout.arrays().iter().zip([&ranges[..], &intensities[..]]) {
            assert_eq!(array.range().len(), values.len() * 4);
            let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            buffer[array.range()].copy_from_slice(&bytes);
        }
        layout.write_around(&scan, &mut buffer).unwrap();
        scan.set("ranges", Value::F32s(Numbers::from(ranges.to_vec())))
            .unwrap();
        scan.set(
            "intensities",
            Value::F32s(Numbers::from(intensities.to_vec())),
        )
        .unwrap();
        assert_eq!(buffer, crate::to_vec(&scan).unwrap());
    }

    #[test]
    fn a_string_that_changed_length_before_an_array_is_refused_and_nothing_is_written() {
        let ty = DynamicType::from_description(&PointCloud2::full_description()).unwrap();
        let mut cloud = ty.default_message();
        let layout = ty.lay_out_in_place(&cloud, &[(&["data"], 16)]).unwrap();
        cloud.set("height", Value::U32(1)).unwrap();
        let mut buffer = vec![0x11u8; layout.size()];
        // A fixed-size field may change.
        layout.write_around(&cloud, &mut buffer).unwrap();
        let mut header = cloud.message("header").unwrap().to_message();
        header
            .set("frame_id", Value::String("longer".into()))
            .unwrap();
        cloud
            .set("header", Value::Message(Box::new(header)))
            .unwrap();
        let mut untouched = vec![0x22u8; layout.size()];
        assert_eq!(
            layout.write_around(&cloud, &mut untouched),
            Err(InPlaceError::Moved {
                field: "data".into()
            })
        );
        assert!(untouched.iter().all(|&b| b == 0x22));
    }

    #[test]
    fn what_cannot_be_filled_in_place_is_named_with_what_to_do() {
        let ty = DynamicType::from_description(&PointCloud2::full_description()).unwrap();
        let cloud = ty.default_message();
        let reason = |path: &[&str], n| match ty.lay_out_in_place(&cloud, &[(path, n)]) {
            Err(InPlaceError::Field { field, reason, .. }) => format!("{field}: {reason}"),
            other => panic!("{other:?}"),
        };
        assert!(reason(&["dat"], 1).contains("its fields: header, height"));
        assert!(reason(&["fields", "name"], 1).contains("sequence of messages"));
        assert!(reason(&["is_dense"], 1).contains("set it as a value"));
        assert!(reason(&["header", "frame_id"], 1).contains("not a sequence of numbers"));
        assert!(reason(&[], 1).contains("name a field"));
        let twice = ty.lay_out_in_place(&cloud, &[(&["data"], 1), (&["data"], 2)]);
        assert!(
            matches!(twice, Err(InPlaceError::Field { reason, .. }) if reason.contains("twice"))
        );
        let image =
            DynamicType::from_description(&crate::msgs::sensor_msgs::Image::full_description())
                .unwrap();
        let other = image.lay_out_in_place(&cloud, &[(&["data"], 1)]);
        assert!(matches!(other, Err(InPlaceError::OtherType { .. })));
    }

    #[test]
    fn a_buffer_too_small_is_an_error() {
        let ty = DynamicType::from_description(&PointCloud2::full_description()).unwrap();
        let cloud = ty.default_message();
        let layout = ty.lay_out_in_place(&cloud, &[(&["data"], 64)]).unwrap();
        let mut short = vec![0u8; layout.size() - 1];
        assert!(matches!(
            layout.write_around(&cloud, &mut short),
            Err(InPlaceError::Encode(_))
        ));
        assert!(matches!(
            layout.write_around(&cloud, &mut [0u8; 2]),
            Err(InPlaceError::Encode(_))
        ));
    }
}
