//! What the ping and echo processes agree on: the paths, the Zenoh setups, the
//! shared clock, the message contents and the pong.

use std::time::Duration;

use zenoh::Config;

/// Data sizes of the PointCloud2 (the `data` field; the message adds ~150 bytes).
pub const SIZES: [(usize, &str); 4] = [
    (64, "64 B"),
    (64 << 10, "64 KiB"),
    (1 << 20, "1 MiB"),
    (8 << 20, "8 MiB"),
];

/// Key expression of the pongs (echo → ping).
pub const PONG_KEY: &str = "xproc/pong";
/// Key expression the ping puts on when it is done, so the echo exits cleanly
/// (and its shared memory is unlinked).
pub const DONE_KEY: &str = "xproc/done";
/// How long a pong may take before its message counts as lost.
pub const PONG_TIMEOUT: Duration = Duration::from_secs(2);
/// From this data size a heap payload no longer fits one lowlatency frame (the
/// batch is at most 64 KiB), so lowlatency setups do not send it on the paths
/// that put heap payloads ([`Path::puts_heap`]).
pub const UNFRAGMENTABLE_FROM: usize = 64 << 10;
/// SHM pool of each publishing side: room for every path's 8 MiB chunk at once.
pub const POOL: usize = 96 << 20;

/// One way of publishing a PointCloud2 and receiving it in the other process.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
pub enum Path {
    /// Ours: the cloud built in place in its SHM chunk before the clock; borrowed decode.
    Loan,
    /// Ours: a fresh `ShmBytes` data buffer filled before the clock, spliced; borrowed decode.
    Splice,
    /// Ours: `Vec` data serialized into an exact-size SHM chunk on publish; borrowed decode.
    Automatic,
    /// What a user writes by hand: `shm_cdr::to_vec` + a plain Zenoh `put`; owned decode.
    ToVecPut,
    /// The floor: a pre-filled `ZShmMut` of the same size put as is; contiguous bytes, no decode.
    Floor,
    /// hiroz 0.2.1: `Vec` data, its automatic SHM threshold; its `recv()` (owned decode).
    HirozAutomatic,
    /// hiroz 0.2.1: data in a `ZShmMut` allocated and filled before the clock; its `recv()`.
    HirozShm,
    /// The floor in a splice's shape: a raw put of [heap head, pre-filled `ZShmMut`
    /// data, heap tail]; borrowed slices, no decode.
    FloorFragments,
}

impl Path {
    pub const ALL: [Path; 8] = [
        Path::Loan,
        Path::Splice,
        Path::Automatic,
        Path::ToVecPut,
        Path::Floor,
        Path::HirozAutomatic,
        Path::HirozShm,
        Path::FloorFragments,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Path::Loan => "ours: loan (built in place)",
            Path::Splice => "ours: ShmBytes splice, fresh buffer",
            Path::Automatic => "ours: automatic (Vec → SHM)",
            Path::ToVecPut => "to_vec + put, owned decode",
            Path::Floor => "floor: pre-filled ZShmMut",
            Path::HirozAutomatic => "hiroz 0.2.1: automatic SHM",
            Path::HirozShm => "hiroz 0.2.1: ZShmMut data",
            Path::FloorFragments => "floor: 3 fragments (heap, ZShmMut, heap)",
        }
    }

    /// Whether this path puts a heap payload through plain Zenoh (so under
    /// lowlatency, where Zenoh cannot fragment, a large one is lost).
    /// Another project's path: its echo failing marks its row; ours failing
    /// fails the run.
    pub fn is_theirs(self) -> bool {
        matches!(self, Path::HirozAutomatic | Path::HirozShm)
    }

    pub fn puts_heap(self) -> bool {
        matches!(self, Path::ToVecPut | Path::HirozAutomatic)
    }

    /// A word or two for the summary's ratios.
    pub fn short(self) -> &'static str {
        match self {
            Path::Loan => "loan",
            Path::Splice => "splice",
            Path::Automatic => "automatic",
            Path::ToVecPut => "to_vec",
            Path::Floor => "floor",
            Path::HirozAutomatic => "hiroz automatic",
            Path::HirozShm => "hiroz ZShmMut",
            Path::FloorFragments => "3-fragment floor",
        }
    }

    /// Key expression (or hiroz topic name) of this path's messages.
    pub fn key(self) -> &'static str {
        match self {
            Path::Loan => "xproc/loan",
            Path::Splice => "xproc/splice",
            Path::Automatic => "xproc/automatic",
            Path::ToVecPut => "xproc/to_vec",
            Path::Floor => "xproc/floor",
            Path::HirozAutomatic => "xproc_hiroz_automatic",
            Path::HirozShm => "xproc_hiroz_shm",
            Path::FloorFragments => "xproc/floor_fragments",
        }
    }

    pub fn from_u8(tag: u8) -> Option<Path> {
        Path::ALL.get(usize::from(tag)).copied()
    }
}

/// A Zenoh configuration under test: Zenoh's defaults plus the listed changes.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    pub name: &'static str,
    /// Connect over a Unix-domain socket instead of TCP on 127.0.0.1.
    pub unix_socket: bool,
    /// `transport/unicast/qos/enabled`.
    pub qos: bool,
    /// `transport/unicast/lowlatency` (needs QoS off).
    pub lowlatency: bool,
    /// `transport/link/tx/queue/batching/enabled`.
    pub batching: bool,
    /// `ZENOH_RUNTIME` for both processes (RON, Zenoh's thread pools).
    pub runtime: Option<&'static str>,
    /// Subscribers decode in a callback on Zenoh's receiving thread, instead of
    /// a thread of the application's blocking in `recv` (one thread hand-off less).
    pub callback: bool,
    /// Whether idle CPUs may halt (the host's default). `false`: the orchestrator
    /// holds `/dev/cpu_dma_latency` at 0 for the setup, so an idle CPU polls
    /// instead of halting and a wake-up costs no exit to the hypervisor (or no
    /// deep C-state on bare metal). Needs write access to that file (root).
    pub idle_halts: bool,
}

/// Zenoh's defaults (TCP on loopback).
pub const DEFAULT: Setup = Setup {
    name: "default",
    unix_socket: false,
    qos: true,
    lowlatency: false,
    batching: true,
    runtime: None,
    callback: false,
    idle_halts: true,
};

/// All of Zenoh's thread pools handed over to one receiving thread: fewer
/// threads to wake per message (Zenoh's default is 6 workers in 5 pools).
pub const ONE_THREAD_POOL: &str =
    "(rx: (worker_threads: 1), tx: (handover: rx), net: (handover: rx), acc: (handover: rx), app: (handover: rx))";

/// Every knob alone, then the combinations (see the README).
pub const SETUPS: [Setup; 13] = [
    DEFAULT,
    Setup {
        name: "unix socket",
        unix_socket: true,
        ..DEFAULT
    },
    Setup {
        name: "QoS off",
        qos: false,
        ..DEFAULT
    },
    Setup {
        name: "lowlatency (QoS off)",
        qos: false,
        lowlatency: true,
        ..DEFAULT
    },
    Setup {
        name: "batching off",
        batching: false,
        ..DEFAULT
    },
    Setup {
        name: "one thread pool",
        runtime: Some(ONE_THREAD_POOL),
        ..DEFAULT
    },
    Setup {
        name: "callback subscribers",
        callback: true,
        ..DEFAULT
    },
    RECOMMENDED,
    Setup {
        name: "recommended over TCP",
        unix_socket: false,
        ..RECOMMENDED
    },
    Setup {
        name: "recommended + lowlatency",
        lowlatency: true,
        ..RECOMMENDED
    },
    Setup {
        name: "default + no idle halts",
        idle_halts: false,
        ..DEFAULT
    },
    Setup {
        name: "recommended + no idle halts",
        idle_halts: false,
        ..RECOMMENDED
    },
    Setup {
        name: "recommended + lowlatency + no idle halts",
        lowlatency: true,
        idle_halts: false,
        ..RECOMMENDED
    },
];

/// The combination the measurements recommend for any traffic: every Zenoh knob
/// that helped and loses nothing. lowlatency helps too, but Zenoh drops any
/// message that is not in shared memory and larger than a batch (64 KiB); our
/// publishers refuse those with an error, plain puts lose them.
pub const RECOMMENDED: Setup = Setup {
    name: "recommended",
    unix_socket: true,
    qos: false,
    lowlatency: false,
    batching: true,
    runtime: Some(ONE_THREAD_POOL),
    callback: true,
    idle_halts: true,
};

impl Setup {
    pub fn by_name(name: &str) -> Option<Setup> {
        SETUPS.iter().find(|s| s.name == name).copied()
    }

    /// A peer session's configuration: listening on `endpoint` (the ping) or
    /// connecting to it (the echo). Scouting is off so that the two processes
    /// meet only each other.
    pub fn config(&self, endpoint: &str, listen: bool) -> zenoh::Result<Config> {
        let mut c = Config::default();
        c.insert_json5("mode", "\"peer\"")?;
        c.insert_json5("scouting/multicast/enabled", "false")?;
        c.insert_json5("scouting/gossip/enabled", "false")?;
        let side = if listen {
            "listen/endpoints"
        } else {
            "connect/endpoints"
        };
        c.insert_json5(side, &format!("[\"{endpoint}\"]"))?;
        if !self.qos {
            c.insert_json5("transport/unicast/qos/enabled", "false")?;
        }
        if self.lowlatency {
            c.insert_json5("transport/unicast/lowlatency", "true")?;
        }
        if !self.batching {
            c.insert_json5("transport/link/tx/queue/batching/enabled", "false")?;
        }
        Ok(c)
    }
}

/// CLOCK_MONOTONIC in nanoseconds: one clock for every process on this host, so
/// a time taken in the ping and one taken in the echo can be subtracted.
pub fn now_ns() -> u64 {
    use nix::time::{clock_gettime, ClockId};
    // CLOCK_MONOTONIC always exists on Linux; a failure would be a broken kernel.
    let t = clock_gettime(ClockId::CLOCK_MONOTONIC).expect("CLOCK_MONOTONIC");
    t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
}

/// Every data byte of message `seq`: the echo checks all of them, so a stale,
/// reused or torn buffer fails the run instead of timing well.
pub fn fill_byte(seq: u64) -> u8 {
    (seq % 251) as u8 + 1
}

/// The sequence number rides in `header.stamp.sec` (`frame_id` says which path).
pub fn stamp_sec(seq: u64) -> i32 {
    (seq & 0x7fff_ffff) as i32
}

/// Whether a received cloud is message `seq`'s: every data byte (in one or more
/// parts), the length the row step announces, and the frame.
pub fn cloud_ok(frame_id: &str, row_step: u32, data: &[&[u8]], seq: u64) -> bool {
    frame_id == "xproc"
        && data.iter().map(|part| part.len()).sum::<usize>() == row_step as usize
        && data
            .iter()
            .all(|part| part.iter().all(|&b| b == fill_byte(seq)))
}

/// Whether a floor payload is message `seq`'s: the sequence number in its first 8
/// bytes, then [`fill_byte`] throughout.
pub fn floor_ok(payload: &[u8]) -> Option<u64> {
    let (head, rest) = payload.split_first_chunk::<8>()?;
    let seq = u64::from_le_bytes(*head);
    rest.iter().all(|&b| b == fill_byte(seq)).then_some(seq)
}

/// Echo → ping: which message arrived, when (CLOCK_MONOTONIC), and whether
/// every byte of it was right.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pong {
    pub path: u8,
    pub ok: bool,
    pub seq: u64,
    pub at_ns: u64,
}

impl Pong {
    pub const LEN: usize = 18;

    pub fn to_bytes(self) -> [u8; Self::LEN] {
        let mut out = [0u8; Self::LEN];
        out[0] = self.path;
        out[1] = u8::from(self.ok);
        out[2..10].copy_from_slice(&self.seq.to_le_bytes());
        out[10..18].copy_from_slice(&self.at_ns.to_le_bytes());
        out
    }

    pub fn parse(bytes: &[u8]) -> Option<Pong> {
        let bytes: &[u8; Self::LEN] = bytes.try_into().ok()?;
        let (path, rest) = bytes.split_first()?;
        let (ok, rest) = rest.split_first()?;
        let (seq, at) = rest.split_first_chunk::<8>()?;
        Some(Pong {
            path: *path,
            ok: *ok == 1,
            seq: u64::from_le_bytes(*seq),
            at_ns: u64::from_le_bytes(at.try_into().ok()?),
        })
    }
}
