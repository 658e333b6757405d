//! Differential check input: random values of several message shapes, each with
//! our little- and big-endian encoding (or our error, for values over a bound), as
//! JSON lines for `tests/interop/check.py` to compare with rosbags and pycdr2.
//!
//! `interop_differential <count> <seed>`

use serde_json::{json, Value};
use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::{BoundedString, BoundedVec, CdrEncode, Endianness, RosMessage};

#[derive(RosMessage)]
#[ros(type_name = "diff_msgs/msg/Scalars")]
struct Scalars {
    flag: bool,
    a: u8,
    b: i8,
    c: u16,
    d: i16,
    e: u32,
    f: i32,
    g: u64,
    h: i64,
    x: f32,
    y: f64,
}

#[derive(RosMessage)]
#[ros(type_name = "diff_msgs/msg/Strings")]
struct Strings {
    s: String,
    bs: BoundedString<8>,
    many: Vec<String>,
    pair: [String; 2],
}

#[derive(RosMessage, Clone)]
#[ros(type_name = "diff_msgs/msg/Seqs")]
struct Seqs {
    lead: u8,
    f: Vec<f64>,
    bi: BoundedVec<i16, 4>,
    blob: Vec<u8>,
    flags: Vec<bool>,
}

#[derive(RosMessage)]
#[ros(type_name = "diff_msgs/msg/Nested")]
struct Nested {
    tag: u8,
    stamps: Vec<Time>,
    inner: Seqs,
    arr: [f32; 3],
}

/// xorshift64*: reproducible from the seed, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn f64(&mut self) -> f64 {
        loop {
            let v = f64::from_bits(self.next());
            if v.is_finite() {
                return v;
            }
        }
    }
    fn f32(&mut self) -> f32 {
        loop {
            let v = f32::from_bits(self.next() as u32);
            if v.is_finite() {
                return v;
            }
        }
    }
    fn string(&mut self, max: u64) -> String {
        let alphabet = ['a', 'Z', '0', ' ', '/', 'é', 'ß', '✓', '𝄞', '_'];
        (0..self.below(max + 1))
            .map(|_| alphabet[self.below(alphabet.len() as u64) as usize])
            .collect()
    }
    fn seqs(&mut self) -> Seqs {
        Seqs {
            lead: self.next() as u8,
            f: (0..self.below(5)).map(|_| self.f64()).collect(),
            bi: (0..self.below(6)).map(|_| self.next() as i16).collect(), // may exceed 4
            blob: (0..self.below(20)).map(|_| self.next() as u8).collect(),
            flags: (0..self.below(4)).map(|_| self.next() & 1 == 1).collect(),
        }
    }
}

fn seqs_json(m: &Seqs) -> Value {
    json!({"lead": m.lead, "f": m.f, "bi": *m.bi, "blob": m.blob, "flags": m.flags})
}

fn emit<T: RosMessage + CdrEncode>(msg: &T, value: Value) {
    let hex = |e| {
        shm_cdr::to_vec_with(msg, e)
            .map(|b| b.iter().map(|x| format!("{x:02x}")).collect::<String>())
    };
    let line = match (hex(Endianness::Little), hex(Endianness::Big)) {
        (Ok(le), Ok(be)) => json!({"type": T::TYPE_NAME, "value": value, "le": le, "be": be}),
        (Err(e), _) | (_, Err(e)) => {
            json!({"type": T::TYPE_NAME, "value": value, "error": e.to_string()})
        }
    };
    println!("{line}");
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let count: usize = args.get(1).map_or(Ok(1000), |c| c.parse())?;
    let mut rng = Rng(args.get(2).map_or(Ok(0x5eed), |s| s.parse())? | 1);
    for i in 0..count {
        match i % 4 {
            0 => {
                let m = Scalars {
                    flag: rng.next() & 1 == 1,
                    a: rng.next() as u8,
                    b: rng.next() as i8,
                    c: rng.next() as u16,
                    d: rng.next() as i16,
                    e: rng.next() as u32,
                    f: rng.next() as i32,
                    g: rng.next(),
                    h: rng.next() as i64,
                    x: rng.f32(),
                    y: rng.f64(),
                };
                let v = json!({"flag": m.flag, "a": m.a, "b": m.b, "c": m.c, "d": m.d, "e": m.e, "f": m.f,
                               "g": m.g, "h": m.h, "x": f64::from(m.x), "y": m.y});
                emit(&m, v);
            }
            1 => {
                let m = Strings {
                    s: rng.string(12),
                    bs: rng.string(10).into(), // may exceed 8 bytes
                    many: (0..rng.below(4)).map(|_| rng.string(6)).collect(),
                    pair: [rng.string(5), rng.string(5)],
                };
                let v = json!({"s": m.s, "bs": *m.bs, "many": m.many, "pair": m.pair});
                emit(&m, v);
            }
            2 => {
                let m = rng.seqs();
                emit(&m, seqs_json(&m));
            }
            _ => {
                let m = Nested {
                    tag: rng.next() as u8,
                    stamps: (0..rng.below(4))
                        .map(|_| Time {
                            sec: rng.next() as i32,
                            nanosec: rng.next() as u32,
                        })
                        .collect(),
                    inner: rng.seqs(),
                    arr: [rng.f32(), rng.f32(), rng.f32()],
                };
                let v = json!({"tag": m.tag,
                               "stamps": m.stamps.iter().map(|t| json!({"sec": t.sec, "nanosec": t.nanosec})).collect::<Vec<_>>(),
                               "inner": seqs_json(&m.inner), "arr": m.arr.map(f64::from)});
                emit(&m, v);
            }
        }
    }
    Ok(())
}
