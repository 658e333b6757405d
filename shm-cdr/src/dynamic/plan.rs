//! How a message of each struct of a [`DynamicType`](super::DynamicType) is
//! laid out and walked: one slot per field that is not a message nested by
//! value, in field order with each nested message's slots in its place
//! (pre-order), and the steps a view checks it by. A decoded
//! [`Message`](super::Message) keeps its values in these slots, and a
//! [view](super::MessageView) notes where each lies in these slots: the two
//! agree on one layout.

use super::structs::{Check, Element, StructDef};
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
        /// The members as `encode` writes them: consecutive single values
        /// of one kind folded into one loop.
        reads: Box<[RunRead]>,
        /// The members as `decode` reads them: one load per value, its kind
        /// in the load's own tag.
        loads: Box<[Load]>,
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
/// by one: a loop's set-up costs more than a few dispatches.
const SINGLE_LOADS: usize = 4;

/// How `decode` reads one member of a [`Step::Run`] from the run's bytes:
/// a single value's kind is the load's tag, so each value costs one
/// dispatch; offsets count from the run's aligned start.
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
    /// `element` back to back
    /// from `offset`, one value each: read in one loop.
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
    /// rosidl's placeholder member of an empty message: reads as 0.
    Placeholder,
}

impl Load {
    /// The members of a run as loads, in slot order: more than
    /// [`SINGLE_LOADS`] single numbers of one kind back to back are one
    /// load, as [`RunRead::of`] folds them; bools are one load each, each
    /// checked.
    fn of(members: &[Member]) -> Box<[Load]> {
        let mut loads = Vec::with_capacity(members.len());
        for read in RunRead::of(members).iter() {
            match *read {
                RunRead::Singles {
                    element,
                    offset,
                    count,
                    ..
                } if count > SINGLE_LOADS && element != Element::Bool => {
                    loads.push(Load::Singles {
                        element,
                        offset,
                        count,
                    })
                }
                RunRead::Singles {
                    element,
                    offset,
                    count,
                    ..
                } => {
                    let size = element.fixed_size().unwrap_or(1);
                    loads.extend((0..count).map(|i| Load::single(element, offset + i * size)));
                }
                RunRead::Array {
                    element, offset, n, ..
                } => loads.push(Load::Array { element, offset, n }),
                RunRead::Placeholder => loads.push(Load::Placeholder),
            }
        }
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
            // arrays of numbers in one): a load that cannot be read sends
            // the run field by field.
            Element::String(_) | Element::WString(_) | Element::Message(_) => Load::Singles {
                element,
                offset: at,
                count: 1,
            },
        }
    }
}

/// How `encode` writes the members of a [`Step::Run`], in slot order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RunRead {
    /// `count` single numbers or bools of kind `element`, back to back from
    /// `offset`: one value each, in the slots from `slot` on.
    Singles {
        slot: usize,
        element: Element,
        offset: usize,
        count: usize,
    },
    /// An array of `n` numbers of kind `element` at `offset`: one value, in
    /// `slot`.
    Array {
        slot: usize,
        element: Element,
        offset: usize,
        n: usize,
    },
    /// rosidl's placeholder member of an empty message: reads as 0, and is
    /// written as 0.
    Placeholder,
}

impl RunRead {
    /// The members of a run as reads: a single value whose kind is the
    /// previous one's and which starts where that one ends joins it.
    fn of(members: &[Member]) -> Box<[RunRead]> {
        let mut reads: Vec<RunRead> = Vec::with_capacity(members.len());
        for m in members {
            let read = match m.container {
                _ if m.placeholder => RunRead::Placeholder,
                Container::Array(n) => RunRead::Array {
                    slot: m.slot,
                    element: m.element,
                    offset: m.offset,
                    n,
                },
                _ => {
                    if let Some(RunRead::Singles {
                        slot,
                        element,
                        offset,
                        count,
                    }) = reads.last_mut()
                    {
                        let end = m
                            .element
                            .fixed_size()
                            .and_then(|size| size.checked_mul(*count))
                            .and_then(|len| offset.checked_add(len));
                        // A run's members take consecutive slots.
                        if *element == m.element
                            && end == Some(m.offset)
                            && slot.checked_add(*count) == Some(m.slot)
                        {
                            *count += 1;
                            continue;
                        }
                    }
                    RunRead::Singles {
                        slot: m.slot,
                        element: m.element,
                        offset: m.offset,
                        count: 1,
                    }
                }
            };
            reads.push(read);
        }
        reads.into()
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
        Step::Run {
            align: self.align,
            len: self.len,
            bools: self.members.iter().any(|m| m.bool),
            reads: RunRead::of(&self.members),
            loads: Load::of(&self.members),
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
    use super::{RunRead, Step};
    use crate::dynamic::{DynamicType, Element};
    use crate::msgs::sensor_msgs::msg::Imu;
    use crate::RosMessage;

    /// An Imu's orientation, velocities and their covariances are one run;
    /// `decode` reads it as three runs of single numbers and three arrays,
    /// not as fifteen values one by one.
    #[test]
    fn single_numbers_of_one_kind_back_to_back_are_read_at_once() {
        let ty = DynamicType::from_description(&Imu::full_description()).unwrap();
        let runs: Vec<&[RunRead]> = ty.inner.plans[0]
            .steps
            .iter()
            .filter_map(|step| match step {
                Step::Run { reads, .. } => Some(&reads[..]),
                _ => None,
            })
            .collect();
        let singles = |slot, offset, count| RunRead::Singles {
            slot,
            element: Element::F64,
            offset,
            count,
        };
        let covariance = |slot, offset| RunRead::Array {
            slot,
            element: Element::F64,
            offset,
            n: 9,
        };
        // The stamp's seconds and nanoseconds differ in kind: two reads.
        assert_eq!(
            runs,
            [
                &[
                    RunRead::Singles {
                        slot: 0,
                        element: Element::I32,
                        offset: 0,
                        count: 1
                    },
                    RunRead::Singles {
                        slot: 1,
                        element: Element::U32,
                        offset: 4,
                        count: 1
                    },
                ][..],
                // Slot 2 is the frame_id.
                &[
                    singles(3, 0, 4),
                    covariance(7, 32),
                    singles(8, 104, 3),
                    covariance(11, 128),
                    singles(12, 200, 3),
                    covariance(15, 224),
                ][..],
            ]
        );
    }
}
