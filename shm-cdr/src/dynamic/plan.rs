//! How a message of each struct of a [`DynamicType`](super::DynamicType) is
//! laid out and walked: one slot per field that is not a message nested by
//! value, in field order with each nested message's slots in its place
//! (pre-order), and the steps a view checks it by. A decoded
//! [`Message`](super::Message) keeps its values in these slots, and a
//! [view](super::MessageView) notes where each lies in these slots: the two
//! agree on one layout.

use super::structs::{Check, Element, StructDef};
use super::value::Value;
use crate::describe::Container;

/// How one message of a struct is laid out and checked: its fields, and
/// those of the messages it nests by value, folded into steps; runs of
/// fixed-size fields checked at once.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct StructPlan {
    pub(crate) steps: Vec<Step>,
    /// Slots one message takes: one per field that is not a message nested
    /// by value, with those of the messages it nests by value.
    pub(crate) block: usize,
    /// For each field, its slot, or, for a message nested by value, where
    /// its slots start; counted from the message's first.
    pub(crate) offsets: Vec<usize>,
    /// The fields in slot order, small messages nested by value inlined
    /// (as in `steps`): what decoding, sizing and encoding walk.
    pub(crate) entries: Vec<Entry>,
}

/// One step of a [`StructPlan`]; `slot`s count from the message's first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Step {
    /// Consecutive numbers, bools and arrays of numbers whose offsets from a
    /// start aligned to `align` are fixed: one bounds check for all of them.
    Run {
        align: usize,
        len: usize,
        members: Box<[Member]>,
        /// How each member is checked alone, to find the one at fault.
        checks: Box<[Check]>,
        /// Whether a member is a bool, whose byte must be 0 or 1.
        bools: bool,
        /// The slot of its first member; the others follow, one each.
        first: usize,
        /// The members as `decode` reads them.
        loads: Box<[Load]>,
        /// The members as `encode` writes them (`None`: member by member).
        copies: Option<Box<Copies>>,
    },
    /// A string.
    String { slot: usize, bound: Option<usize> },
    /// A sequence of numbers of `size` bytes each: one bounds check for
    /// them all (any bit pattern is a number). `check` finds the fault.
    Numbers {
        slot: usize,
        container: Container,
        size: usize,
        check: Check,
    },
    /// A wide string, or an array or sequence of values: checked as
    /// [`Check`] says.
    Value {
        slot: usize,
        check: Check,
        element: Element,
    },
    /// A message nested by value, checked by its own plan, its slots from
    /// `first` on.
    Nested { first: usize, index: usize },
    /// An array or sequence of messages, whose slots are added when its
    /// length is known.
    Messages {
        slot: usize,
        index: usize,
        container: Container,
        min: usize,
    },
}

/// One field of a [`Step::Run`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Member {
    pub(crate) slot: usize,
    pub(crate) offset: usize,
    pub(crate) bool: bool,
    /// What it is: a number or bool, or an array of numbers.
    pub(crate) element: Element,
    pub(crate) container: Container,
    /// rosidl's placeholder member of an empty message, which reads as 0.
    pub(crate) placeholder: bool,
}

/// Up to this many single numbers of one kind back to back are loaded one
/// by one: a loop's set-up costs more than two dispatches.
const SINGLE_LOADS: usize = 2;

/// How `decode` reads one member of a [`Step::Run`]
/// in its bytes: a single value's kind is the load's tag, so each value
/// costs one dispatch. Offsets count from the run's aligned start; the
/// loads of a run take its slots in order, one each (`count` for
/// [`Load::Singles`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Load {
    /// A bool, whose byte must be 0 or 1.
    Bool(usize),
    /// A `byte`, `char` or `uint8`.
    U8(usize),
    I8(usize),
    I16(usize),
    U16(usize),
    I32(usize),
    U32(usize),
    I64(usize),
    U64(usize),
    F32(usize),
    F64(usize),
    /// `count` (more than [`SINGLE_LOADS`]) single numbers of kind
    /// `element` back to back from `offset`: read in one loop.
    Singles {
        element: Element,
        offset: usize,
        count: usize,
    },
    /// An array of `n` numbers of kind `element`, borrowed.
    Array {
        element: Element,
        offset: usize,
        n: usize,
    },
    /// rosidl's placeholder member of an empty message: reads as 0, and is
    /// written as 0.
    Placeholder,
}

impl Load {
    /// The members of a run as loads, in slot order: more than
    /// [`SINGLE_LOADS`] single numbers of one kind, each starting where
    /// the one before ends, are one load.
    fn of(members: &[Member]) -> Box<[Load]> {
        let mut loads = Vec::with_capacity(members.len());
        // The single numbers of one kind gathered: kind, offset, count.
        let mut open: Option<(Element, usize, usize)> = None;
        let close = |loads: &mut Vec<Load>, open: Option<(Element, usize, usize)>| {
            let Some((element, offset, count)) = open else {
                return;
            };
            let size = element.fixed_size().unwrap_or(1);
            if count > SINGLE_LOADS {
                loads.push(Load::Singles {
                    element,
                    offset,
                    count,
                });
            } else {
                loads.extend((0..count).map(|i| Load::single(element, offset + i * size)));
            }
        };
        for m in members {
            match m.container {
                _ if m.placeholder => {
                    close(&mut loads, open.take());
                    loads.push(Load::Placeholder);
                }
                Container::Array(n) => {
                    close(&mut loads, open.take());
                    loads.push(Load::Array {
                        element: m.element,
                        offset: m.offset,
                        n,
                    });
                }
                _ => {
                    if let Some((element, offset, count)) = open.as_mut() {
                        let end = m
                            .element
                            .fixed_size()
                            .and_then(|size| size.checked_mul(*count))
                            .and_then(|len| offset.checked_add(len));
                        // Bools are checked one by one.
                        if *element == m.element
                            && m.element != Element::Bool
                            && end == Some(m.offset)
                        {
                            *count += 1;
                            continue;
                        }
                    }
                    close(&mut loads, open.take());
                    open = Some((m.element, m.offset, 1));
                }
            }
        }
        close(&mut loads, open);
        loads.into()
    }

    /// One single value of kind `element` at `at`.
    fn single(element: Element, at: usize) -> Load {
        match element {
            Element::Bool => Load::Bool(at),
            Element::Byte | Element::Char | Element::U8 => Load::U8(at),
            Element::I8 => Load::I8(at),
            Element::I16 => Load::I16(at),
            Element::U16 => Load::U16(at),
            Element::I32 => Load::I32(at),
            Element::U32 => Load::U32(at),
            Element::I64 => Load::I64(at),
            Element::U64 => Load::U64(at),
            Element::F32 => Load::F32(at),
            Element::F64 => Load::F64(at),
            // Never a member of a run (`steps` puts only numbers, bools and
            // arrays of numbers in one): a load that cannot be read or
            // written sends the run field by field.
            Element::String(_) | Element::WString(_) | Element::Message(_) => Load::Singles {
                element,
                offset: at,
                count: 1,
            },
        }
    }

    /// How many slots the load takes.
    pub(crate) fn slots(&self) -> usize {
        match *self {
            Load::Singles { count, .. } => count,
            _ => 1,
        }
    }
}

/// A run's members as `encode` writes them: its single numbers and bools
/// grouped by size, each group a loop with no branch on a value's kind, and
/// its arrays copied whole. Every slot of the run is in exactly one of them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Copies {
    /// The slots the run takes.
    pub(crate) count: usize,
    pub(crate) ones: Box<[Copy<u8>]>,
    pub(crate) twos: Box<[Copy<u16>]>,
    pub(crate) fours: Box<[Copy<u32>]>,
    pub(crate) eights: Box<[Copy<u64>]>,
    /// `(slot, offset)`: an array of numbers.
    pub(crate) arrays: Box<[(usize, usize)]>,
}

/// One single number or bool of a run: its offset in the run's bytes and
/// its slot from the run's first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Copy<B> {
    pub(crate) at: usize,
    pub(crate) slot: usize,
    /// What of its bits it keeps: all, or none for rosidl's placeholder
    /// member of an empty message, which is written as 0.
    pub(crate) keep: B,
}

/// The bits of a single number or bool as a run copies them: `u8`, `u16`,
/// `u32` or `u64`, one type per size.
pub(crate) trait Bits: std::marker::Copy + std::ops::BitAnd<Output = Self> {
    const ALL: Self;
    const NONE: Self;
    /// The bits of a number or bool of this size; `None` for another value.
    fn of(value: &Value<'_>) -> Option<Self>;
    /// Write them at the start of `out` in the byte order `little` says;
    /// `false` if they do not fit.
    fn write(self, out: &mut [u8], little: bool) -> bool;
}

macro_rules! bits {
    ($t:ty: $($variant:ident => $to_bits:expr),*) => {
        impl Bits for $t {
            const ALL: Self = <$t>::MAX;
            const NONE: Self = 0;
            #[inline(always)]
            fn of(value: &Value<'_>) -> Option<Self> {
                match *value {
                    $(Value::$variant(v) => Some($to_bits(v)),)*
                    _ => None,
                }
            }
            #[inline(always)]
            fn write(self, out: &mut [u8], little: bool) -> bool {
                let Some(out) = out.first_chunk_mut::<{ size_of::<$t>() }>() else {
                    return false;
                };
                *out = if little { self.to_le_bytes() } else { self.to_be_bytes() };
                true
            }
        }
    };
}
bits!(u8: Bool => u8::from, U8 => |v| v, I8 => |v: i8| v as u8);
bits!(u16: I16 => |v: i16| v as u16, U16 => |v| v);
bits!(u32: I32 => |v: i32| v as u32, U32 => |v| v, F32 => f32::to_bits);
bits!(u64: I64 => |v: i64| v as u64, U64 => |v| v, F64 => f64::to_bits);

impl<B: Bits> Copy<B> {
    /// The bits `value` is written as, if it is a number or bool of this size.
    #[inline(always)]
    pub(crate) fn bits(&self, value: &Value<'_>) -> Option<B> {
        B::of(value).map(|bits| bits & self.keep)
    }
}

impl Copies {
    /// The copies of a run's members, slots counted from the first; `None`
    /// if a member is not a number, a bool or an array of numbers.
    fn of(members: &[Member]) -> Option<Box<Copies>> {
        fn copy<B: Bits>(m: &Member, slot: usize) -> Copy<B> {
            Copy {
                at: m.offset,
                slot,
                keep: if m.placeholder { B::NONE } else { B::ALL },
            }
        }
        let first = members.first().map_or(0, |m| m.slot);
        let (mut ones, mut twos, mut fours, mut eights, mut arrays) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for m in members {
            let slot = m.slot.checked_sub(first)?;
            match (m.container, m.element.fixed_size()?) {
                (Container::Array(_), _) if m.element.is_number() => arrays.push((slot, m.offset)),
                (Container::Single, 1) => ones.push(copy(m, slot)),
                (Container::Single, 2) => twos.push(copy(m, slot)),
                (Container::Single, 4) => fours.push(copy(m, slot)),
                (Container::Single, 8) => eights.push(copy(m, slot)),
                _ => return None,
            }
        }
        let copies = Copies {
            count: members.len(),
            ones: ones.into(),
            twos: twos.into(),
            fours: fours.into(),
            eights: eights.into(),
            arrays: arrays.into(),
        };
        // Each member takes one slot, the run's slots one after another:
        // every value of the run is written, once.
        let mut seen = vec![false; copies.count];
        let slots = copies
            .ones
            .iter()
            .map(|c| c.slot)
            .chain(copies.twos.iter().map(|c| c.slot))
            .chain(copies.fours.iter().map(|c| c.slot))
            .chain(copies.eights.iter().map(|c| c.slot))
            .chain(copies.arrays.iter().map(|a| a.0));
        for slot in slots {
            if std::mem::replace(seen.get_mut(slot)?, true) {
                return None;
            }
        }
        (!seen.contains(&false)).then(|| Box::new(copies))
    }
}

/// Whether every bool among a run's `members` is 0 or 1 in the run's `bytes`.
#[inline]
pub(crate) fn bools_valid(members: &[Member], bytes: &[u8]) -> bool {
    members
        .iter()
        .all(|m| !m.bool || bytes.get(m.offset).is_some_and(|&b| b <= 1))
}

/// A [`Step::Run`] being gathered.
struct OpenRun {
    align: usize,
    len: usize,
    members: Vec<Member>,
    checks: Vec<Check>,
}

impl OpenRun {
    fn close(self) -> Step {
        let loads = Load::of(&self.members);
        // Fields take one slot each in field order, and a run is of fields
        // next to each other: its loads take its slots in order.
        debug_assert!(self.members.windows(2).all(|w| w[0].slot + 1 == w[1].slot));
        debug_assert_eq!(
            loads.iter().map(Load::slots).sum::<usize>(),
            self.members.len()
        );
        Step::Run {
            align: self.align,
            len: self.len,
            bools: self.members.iter().any(|m| m.bool),
            first: self.members.first().map_or(0, |m| m.slot),
            loads,
            copies: Copies::of(&self.members),
            members: self.members.into(),
            checks: self.checks.into(),
        }
    }
}

/// A nested message whose plan has at most this many entries is copied
/// into the plan of the message that nests it by value, so that runs of
/// fixed-size fields continue across it (CDR gives a nested message no
/// alignment of its own: a `Pose` is one run of seven numbers); a larger one
/// is one step that follows its own plan, so that plans take memory linear
/// in the description however its types nest.
const INLINED_ENTRIES: usize = 32;

/// One entry of a plan, in slot order; slots count from the message's
/// first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Entry {
    /// A field that is not a message nested by value.
    Field(Leaf),
    /// A message nested by value, walked by its own plan; its slots start
    /// at `first`.
    Nested { first: usize, index: usize },
}

/// A field that is not a message nested by value: its slot, kind and check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Leaf {
    pub(crate) slot: usize,
    pub(crate) element: Element,
    pub(crate) container: Container,
    pub(crate) check: Check,
    /// rosidl's placeholder member of an empty message, which reads as 0.
    pub(crate) placeholder: bool,
}

impl Entry {
    fn shifted(self, by: usize) -> Self {
        match self {
            Self::Field(leaf) => Self::Field(Leaf {
                slot: leaf.slot + by,
                ..leaf
            }),
            Self::Nested { first, index } => Self::Nested {
                first: first + by,
                index,
            },
        }
    }
}

/// The plan of every struct, built innermost first (`order`); `blocks` are
/// the slots a message of each takes (see [`StructPlan::block`]).
pub(crate) fn plans(
    structs: &[StructDef],
    checks: &[Vec<Check>],
    order: &[usize],
    blocks: &[usize],
) -> Vec<StructPlan> {
    let mut plans = vec![
        StructPlan {
            steps: Vec::new(),
            block: 0,
            offsets: Vec::new(),
            entries: Vec::new(),
        };
        structs.len()
    ];
    for &index in order {
        let (Some(def), Some(fields)) = (structs.get(index), checks.get(index)) else {
            continue;
        };
        let placeholder = matches!(def.fields.as_slice(),
            [field] if field.name == crate::describe::PLACEHOLDER_MEMBER);
        let mut block = 0usize;
        let mut offsets = Vec::with_capacity(def.fields.len());
        let mut entries = Vec::with_capacity(def.fields.len());
        for (field, &check) in def.fields.iter().zip(fields) {
            offsets.push(block);
            match check {
                // Its plan was made first: its block and entries are known.
                Check::Message { index: nested, .. } => {
                    let first = block;
                    block = block.saturating_add(blocks.get(nested).copied().unwrap_or(0));
                    let inner = plans.get(nested).map_or(&[][..], |p| p.entries.as_slice());
                    if inner.len() <= INLINED_ENTRIES {
                        entries.extend(inner.iter().map(|entry| entry.shifted(first)));
                    } else {
                        entries.push(Entry::Nested {
                            first,
                            index: nested,
                        });
                    }
                }
                check => {
                    entries.push(Entry::Field(Leaf {
                        slot: block,
                        element: field.element,
                        container: field.container,
                        check,
                        placeholder,
                    }));
                    block = block.saturating_add(1);
                }
            }
        }
        if let Some(plan) = plans.get_mut(index) {
            plan.block = block;
            plan.offsets = offsets;
            plan.steps = steps(&entries);
            plan.entries = entries;
        }
    }
    plans
}

/// Fold flattened fields into steps: fixed-size fields into runs, a run
/// going on while each field's alignment is at most the first's (then every
/// offset from the run's aligned start is fixed).
fn steps(fields: &[Entry]) -> Vec<Step> {
    let mut steps = Vec::new();
    let mut run: Option<OpenRun> = None;
    for &entry in fields {
        let (slot, check, leaf) = match entry {
            Entry::Field(leaf) => (leaf.slot, leaf.check, leaf),
            Entry::Nested { first, index } => {
                steps.extend(run.take().map(OpenRun::close));
                steps.push(Step::Nested { first, index });
                continue;
            }
        };
        // A fixed-size value: its size, alignment, and whether it is a bool.
        let fixed = match check {
            Check::Number(size) => Some((size, size, false)),
            Check::Bool => Some((1, 1, true)),
            Check::Many {
                element,
                container: Container::Array(n),
                min,
            } if n > 0
                // An empty array is not aligned to: it stays out of runs.
                && element.is_number() =>
            {
                n.checked_mul(min).map(|size| (size, min, false))
            }
            _ => None,
        };
        if let Some((size, align, bool)) = fixed {
            let member = |offset| Member {
                slot,
                offset,
                bool,
                element: leaf.element,
                container: leaf.container,
                placeholder: leaf.placeholder,
            };
            if let Some(open) = run.as_mut().filter(|open| align <= open.align) {
                let offset = crate::layout::align_up(open.len, align);
                if let Some(end) = offset.checked_add(size) {
                    open.members.push(member(offset));
                    open.checks.push(check);
                    open.len = end;
                    continue;
                }
            }
            steps.extend(run.take().map(OpenRun::close));
            run = Some(OpenRun {
                align,
                len: size,
                members: vec![member(0)],
                checks: vec![check],
            });
            continue;
        }
        steps.extend(run.take().map(OpenRun::close));
        steps.push(match check {
            Check::String(bound) => Step::String { slot, bound },
            Check::Many {
                element: Element::Message(index),
                container,
                min,
            } => Step::Messages {
                slot,
                index,
                container,
                min,
            },
            Check::Many {
                element,
                container: container @ (Container::Sequence | Container::BoundedSequence(_)),
                min,
            } if element.is_number() => Step::Numbers {
                slot,
                container,
                size: min,
                check,
            },
            check => Step::Value {
                slot,
                check,
                element: leaf.element,
            },
        });
    }
    steps.extend(run.take().map(OpenRun::close));
    steps
}

#[cfg(all(test, feature = "sensor_msgs"))]
mod tests {
    use super::{Load, Step};
    use crate::dynamic::{DynamicType, Element};
    use crate::msgs::geometry_msgs::msg::Pose;
    use crate::msgs::sensor_msgs::msg::{Imu, PointCloud2};
    use crate::RosMessage;

    /// Each run of a message's plan: its first slot and its loads.
    fn runs(ty: &DynamicType) -> Vec<(usize, Vec<Load>)> {
        ty.inner.plans[0]
            .steps
            .iter()
            .filter_map(|step| match step {
                Step::Run { first, loads, .. } => Some((*first, loads.to_vec())),
                _ => None,
            })
            .collect()
    }

    /// An Imu's orientation, velocities and their covariances are one run:
    /// three loops of single numbers and three arrays each read at once.
    /// The stamp is a run of its own (the frame_id, slot 2, lies between)
    /// of two loads, one by kind each.
    #[test]
    fn a_run_loads_each_value_by_its_kind_and_each_array_at_once() {
        let ty = DynamicType::from_description(&Imu::full_description()).unwrap();
        let singles = |offset, count| Load::Singles {
            element: Element::F64,
            offset,
            count,
        };
        let covariance = |offset| Load::Array {
            element: Element::F64,
            offset,
            n: 9,
        };
        assert_eq!(
            runs(&ty),
            [
                (0, vec![Load::I32(0), Load::U32(4)]),
                (
                    3,
                    vec![
                        singles(0, 4),
                        covariance(32),
                        singles(104, 3),
                        covariance(128),
                        singles(200, 3),
                        covariance(224),
                    ]
                ),
            ]
        );
    }

    /// An Imu's run is written as ten `float64`s in one loop and three
    /// arrays; a PointField's as its `uint8` and two `uint32`s, one loop
    /// per size.
    #[test]
    fn a_run_is_encoded_by_one_loop_per_size() {
        let ty = DynamicType::from_description(&Imu::full_description()).unwrap();
        let copies = |ty: &DynamicType, index: usize, run: usize| {
            ty.inner.plans[index]
                .steps
                .iter()
                .filter_map(|step| match step {
                    Step::Run { copies, .. } => copies.clone(),
                    _ => None,
                })
                .nth(run)
                .unwrap()
        };
        let imu = copies(&ty, 0, 1);
        let eights: Vec<_> = imu.eights.iter().map(|c| (c.slot, c.at)).collect();
        assert_eq!(
            eights,
            [
                (0, 0),
                (1, 8),
                (2, 16),
                (3, 24),
                (5, 104),
                (6, 112),
                (7, 120),
                (9, 200),
                (10, 208),
                (11, 216)
            ]
        );
        assert_eq!(*imu.arrays, [(4, 32), (8, 128), (12, 224)]);
        assert!(imu.ones.is_empty() && imu.twos.is_empty() && imu.fours.is_empty());
        assert_eq!(imu.count, 13);

        let cloud = DynamicType::from_description(&PointCloud2::full_description()).unwrap();
        let field = cloud
            .inner
            .structs
            .iter()
            .position(|s| s.name == "sensor_msgs/msg/PointField");
        let point_field = copies(&cloud, field.unwrap(), 0);
        let ones: Vec<_> = point_field
            .ones
            .iter()
            .map(|c| (c.slot, c.at, c.keep))
            .collect();
        let fours: Vec<_> = point_field.fours.iter().map(|c| (c.slot, c.at)).collect();
        assert_eq!((ones, fours), (vec![(1, 4, u8::MAX)], vec![(0, 0), (2, 8)]));
    }

    /// rosidl's placeholder member of an empty message keeps none of its
    /// bits: it is written as 0.
    #[test]
    fn a_placeholder_is_written_as_zero() {
        let ty =
            DynamicType::from_description(&crate::msgs::std_msgs::msg::Empty::full_description())
                .unwrap();
        let Some(Step::Run {
            copies: Some(copies),
            ..
        }) = ty.inner.plans[0].steps.first()
        else {
            panic!("an empty message is one run");
        };
        assert_eq!(copies.ones.iter().map(|c| c.keep).collect::<Vec<_>>(), [0]);
    }

    /// A Pose's seven `float64`s back to back are one load, read in a loop;
    /// a PointCloud2's `height` and `width` are two loads.
    #[test]
    fn many_single_numbers_of_one_kind_back_to_back_are_one_load() {
        let ty = DynamicType::from_description(&Pose::full_description()).unwrap();
        assert_eq!(
            runs(&ty),
            [(
                0,
                vec![Load::Singles {
                    element: Element::F64,
                    offset: 0,
                    count: 7
                }]
            )]
        );
        let cloud = DynamicType::from_description(&PointCloud2::full_description()).unwrap();
        assert_eq!(runs(&cloud)[1], (3, vec![Load::U32(0), Load::U32(4)]));
    }
}
