//! eProsima Fast-CDR 2.x through the C++ shim in `cpp/fastcdr_shim.cpp`
//! (compiled by `build.rs` only when Fast-CDR is found; see there).

use std::ffi::c_void;
use std::ptr::NonNull;

/// One message kind's entry points, laid out like the shim's `FcdrKind`.
#[repr(C)]
pub struct Kind {
    load: unsafe extern "C" fn(*const u8, usize) -> *mut c_void,
    free: unsafe extern "C" fn(*mut c_void),
    encode: unsafe extern "C" fn(*const c_void, *mut u8, usize) -> usize,
    size: unsafe extern "C" fn(*const c_void) -> usize,
    decode: unsafe extern "C" fn(*mut c_void, *const u8, usize) -> i32,
}

extern "C" {
    static fcdr_header: Kind;
    static fcdr_point_cloud2: Kind;
    static fcdr_image: Kind;
    static fcdr_joint_state: Kind;
    static fcdr_pose_array: Kind;
    static fcdr_string_list: Kind;
    static fcdr_stamped_values: Kind;
}

macro_rules! kinds {
    ($($name:ident => $symbol:ident),* $(,)?) => {$(
        /// The shim's entry points for this message kind.
        pub fn $name() -> &'static Kind {
            // SAFETY: the shim defines the symbol as a constant-initialized
            // `const FcdrKind` that is never written, with the same field order
            // and C function-pointer types as `Kind`; a shared reference to it
            // is valid for the whole program.
            unsafe { &$symbol }
        }
    )*};
}

kinds! {
    header => fcdr_header,
    point_cloud2 => fcdr_point_cloud2,
    image => fcdr_image,
    joint_state => fcdr_joint_state,
    pose_array => fcdr_pose_array,
    string_list => fcdr_string_list,
    stamped_values => fcdr_stamped_values,
}

/// A C++ message object owned by the shim.
pub struct FastMsg {
    kind: &'static Kind,
    obj: NonNull<c_void>,
}

impl FastMsg {
    /// Decode `bytes` (a CDR stream with header) into a new C++ object.
    pub fn load(kind: &'static Kind, bytes: &[u8]) -> Option<Self> {
        // SAFETY: `bytes` is valid for reads of `bytes.len()` bytes for the
        // duration of the call; the shim only reads it and keeps no pointer.
        let obj = unsafe { (kind.load)(bytes.as_ptr(), bytes.len()) };
        NonNull::new(obj).map(|obj| FastMsg { kind, obj })
    }

    /// Serialize into `out`; `None` if Fast-CDR failed (e.g. `out` too small).
    /// Fast-CDR skips its alignment padding, leaving whatever `out` held there.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        // SAFETY: `self.obj` came from this kind's `load` and is still owned by
        // us; `out` is valid for writes of `out.len()` bytes and the shim writes
        // at most that many (Fast-CDR's FastBuffer is bounded by it).
        let written = unsafe { (self.kind.encode)(self.obj.as_ptr(), out.as_mut_ptr(), out.len()) };
        (written != 0).then_some(written)
    }

    /// Fast-CDR's exact size (the rosidl arithmetic), header included.
    pub fn size(&self) -> usize {
        // SAFETY: `self.obj` is a live object of this kind.
        unsafe { (self.kind.size)(self.obj.as_ptr()) }
    }

    /// Decode `bytes` into this object, reusing its allocations.
    pub fn decode(&mut self, bytes: &[u8]) -> bool {
        // SAFETY: `self.obj` is a live object of this kind, borrowed mutably;
        // `bytes` is valid for reads of its length and not retained.
        unsafe { (self.kind.decode)(self.obj.as_ptr(), bytes.as_ptr(), bytes.len()) == 1 }
    }
}

impl Drop for FastMsg {
    fn drop(&mut self) {
        // SAFETY: `self.obj` came from this kind's `load`, was never freed, and
        // is not used after this.
        unsafe { (self.kind.free)(self.obj.as_ptr()) }
    }
}
