// A thin C ABI over eProsima Fast-CDR 2.x for the peer benchmark.
//
// The message structs and the per-field serialize / deserialize / size code
// follow what rosidl_typesupport_fastrtps_cpp generates for ROS 2 messages:
// `cdr << field` for primitives, strings and primitive sequences (Fast-CDR
// copies those in bulk), and an explicit u32 count plus a loop for sequences
// of nested messages. Streams are XCDRv1 with an encapsulation header, as
// rmw_fastrtps and rmw_zenoh_cpp write them.
//
// Every entry point catches Fast-CDR's exceptions and reports failure by its
// return value, so no C++ exception ever crosses into Rust.

#include <cstddef>
#include <cstdint>
#include <new>
#include <string>
#include <vector>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::CdrVersion;
using eprosima::fastcdr::FastBuffer;

namespace {

struct Time {
    int32_t sec = 0;
    uint32_t nanosec = 0;
};
struct Header {
    Time stamp;
    std::string frame_id;
};
struct PointField {
    std::string name;
    uint32_t offset = 0;
    uint8_t datatype = 0;
    uint32_t count = 0;
};
struct PointCloud2 {
    Header header;
    uint32_t height = 0;
    uint32_t width = 0;
    std::vector<PointField> fields;
    bool is_bigendian = false;
    uint32_t point_step = 0;
    uint32_t row_step = 0;
    std::vector<uint8_t> data;
    bool is_dense = false;
};
struct Image {
    Header header;
    uint32_t height = 0;
    uint32_t width = 0;
    std::string encoding;
    uint8_t is_bigendian = 0;
    uint32_t step = 0;
    std::vector<uint8_t> data;
};
struct JointState {
    Header header;
    std::vector<std::string> name;
    std::vector<double> position;
    std::vector<double> velocity;
    std::vector<double> effort;
};
struct Point {
    double x = 0, y = 0, z = 0;
};
struct Quaternion {
    double x = 0, y = 0, z = 0, w = 1;
};
struct Pose {
    Point position;
    Quaternion orientation;
};
struct PoseArray {
    Header header;
    std::vector<Pose> poses;
};
struct StringList {
    Header header;
    std::vector<std::string> names;
};
struct StampedValue {
    Time stamp;
    double value = 0;
};
struct StampedValues {
    Header header;
    std::vector<StampedValue> samples;
};

// ---- size: the rosidl get_serialized_size arithmetic --------------------------

size_t pad(size_t pos, size_t align) { return (align - pos % align) % align; }
template <class P> size_t prim(size_t pos) { return pos + pad(pos, sizeof(P)) + sizeof(P); }
size_t str(size_t pos, const std::string& s) { return prim<uint32_t>(pos) + s.size() + 1; }
template <class P> size_t prims(size_t pos, const std::vector<P>& v) {
    pos = prim<uint32_t>(pos);
    return v.empty() ? pos : pos + pad(pos, sizeof(P)) + v.size() * sizeof(P);
}

size_t size(size_t p, const Time&) { return prim<uint32_t>(prim<int32_t>(p)); }
size_t size(size_t p, const Header& m) { return str(size(p, m.stamp), m.frame_id); }
size_t size(size_t p, const PointField& m) {
    return prim<uint32_t>(prim<uint8_t>(prim<uint32_t>(str(p, m.name))));
}
size_t size(size_t p, const PointCloud2& m) {
    p = prim<uint32_t>(prim<uint32_t>(size(p, m.header)));
    p = prim<uint32_t>(p);
    for (const auto& f : m.fields) p = size(p, f);
    p = prim<uint32_t>(prim<uint32_t>(prim<bool>(p)));
    return prim<bool>(prims(p, m.data));
}
size_t size(size_t p, const Image& m) {
    p = str(prim<uint32_t>(prim<uint32_t>(size(p, m.header))), m.encoding);
    return prims(prim<uint32_t>(prim<uint8_t>(p)), m.data);
}
size_t size(size_t p, const JointState& m) {
    p = prim<uint32_t>(size(p, m.header));
    for (const auto& s : m.name) p = str(p, s);
    return prims(prims(prims(p, m.position), m.velocity), m.effort);
}
size_t size(size_t p, const Pose&) {
    for (int i = 0; i < 7; ++i) p = prim<double>(p);
    return p;
}
size_t size(size_t p, const PoseArray& m) {
    p = prim<uint32_t>(size(p, m.header));
    for (const auto& pose : m.poses) p = size(p, pose);
    return p;
}
size_t size(size_t p, const StringList& m) {
    p = prim<uint32_t>(size(p, m.header));
    for (const auto& s : m.names) p = str(p, s);
    return p;
}
size_t size(size_t p, const StampedValues& m) {
    p = prim<uint32_t>(size(p, m.header));
    for (const auto& s : m.samples) p = prim<double>(size(p, s.stamp));
    return p;
}

// ---- serialize -----------------------------------------------------------------

template <class T> void put_seq(Cdr& cdr, const std::vector<T>& v);
void put(Cdr& cdr, const Time& m) { cdr << m.sec << m.nanosec; }
void put(Cdr& cdr, const Header& m) {
    put(cdr, m.stamp);
    cdr << m.frame_id;
}
void put(Cdr& cdr, const PointField& m) { cdr << m.name << m.offset << m.datatype << m.count; }
void put(Cdr& cdr, const PointCloud2& m) {
    put(cdr, m.header);
    cdr << m.height << m.width;
    put_seq(cdr, m.fields);
    cdr << m.is_bigendian << m.point_step << m.row_step << m.data << m.is_dense;
}
void put(Cdr& cdr, const Image& m) {
    put(cdr, m.header);
    cdr << m.height << m.width << m.encoding << m.is_bigendian << m.step << m.data;
}
void put(Cdr& cdr, const JointState& m) {
    put(cdr, m.header);
    cdr << m.name << m.position << m.velocity << m.effort;
}
void put(Cdr& cdr, const Pose& m) {
    cdr << m.position.x << m.position.y << m.position.z;
    cdr << m.orientation.x << m.orientation.y << m.orientation.z << m.orientation.w;
}
void put(Cdr& cdr, const PoseArray& m) {
    put(cdr, m.header);
    put_seq(cdr, m.poses);
}
void put(Cdr& cdr, const StringList& m) {
    put(cdr, m.header);
    cdr << m.names;
}
void put(Cdr& cdr, const StampedValue& m) {
    put(cdr, m.stamp);
    cdr << m.value;
}
void put(Cdr& cdr, const StampedValues& m) {
    put(cdr, m.header);
    put_seq(cdr, m.samples);
}
template <class T> void put_seq(Cdr& cdr, const std::vector<T>& v) {
    cdr << static_cast<uint32_t>(v.size());
    for (const auto& item : v) put(cdr, item);
}

// ---- deserialize ---------------------------------------------------------------

template <class T> void get_seq(Cdr& cdr, std::vector<T>& v);
void get(Cdr& cdr, Time& m) { cdr >> m.sec >> m.nanosec; }
void get(Cdr& cdr, Header& m) {
    get(cdr, m.stamp);
    cdr >> m.frame_id;
}
void get(Cdr& cdr, PointField& m) { cdr >> m.name >> m.offset >> m.datatype >> m.count; }
void get(Cdr& cdr, PointCloud2& m) {
    get(cdr, m.header);
    cdr >> m.height >> m.width;
    get_seq(cdr, m.fields);
    cdr >> m.is_bigendian >> m.point_step >> m.row_step >> m.data >> m.is_dense;
}
void get(Cdr& cdr, Image& m) {
    get(cdr, m.header);
    cdr >> m.height >> m.width >> m.encoding >> m.is_bigendian >> m.step >> m.data;
}
void get(Cdr& cdr, JointState& m) {
    get(cdr, m.header);
    cdr >> m.name >> m.position >> m.velocity >> m.effort;
}
void get(Cdr& cdr, Pose& m) {
    cdr >> m.position.x >> m.position.y >> m.position.z;
    cdr >> m.orientation.x >> m.orientation.y >> m.orientation.z >> m.orientation.w;
}
void get(Cdr& cdr, PoseArray& m) {
    get(cdr, m.header);
    get_seq(cdr, m.poses);
}
void get(Cdr& cdr, StringList& m) {
    get(cdr, m.header);
    cdr >> m.names;
}
void get(Cdr& cdr, StampedValue& m) {
    get(cdr, m.stamp);
    cdr >> m.value;
}
void get(Cdr& cdr, StampedValues& m) {
    get(cdr, m.header);
    get_seq(cdr, m.samples);
}
template <class T> void get_seq(Cdr& cdr, std::vector<T>& v) {
    uint32_t count = 0;
    cdr >> count;
    // Like rosidl's generated code this trusts the count (a hostile count makes
    // it allocate before reading); the shim only ever reads bytes we wrote.
    v.resize(count);
    for (auto& item : v) get(cdr, item);
}

template <class T> bool decode_into(T& m, const uint8_t* bytes, size_t len) {
    try {
        FastBuffer fb(reinterpret_cast<char*>(const_cast<uint8_t*>(bytes)), len);
        Cdr cdr(fb, Cdr::DEFAULT_ENDIAN, CdrVersion::XCDRv1);
        cdr.read_encapsulation();
        get(cdr, m);
        return true;
    } catch (...) {
        return false;
    }
}

template <class T> size_t encode(const T& m, uint8_t* out, size_t cap) {
    try {
        FastBuffer fb(reinterpret_cast<char*>(out), cap);
        Cdr cdr(fb, Cdr::DEFAULT_ENDIAN, CdrVersion::XCDRv1);
        cdr.serialize_encapsulation();
        put(cdr, m);
        return cdr.get_serialized_data_length();
    } catch (...) {
        return 0;
    }
}

}  // namespace

// The exported ABI: one table of entry points per message kind, matching
// `peer_bench::fastcdr::Kind` on the Rust side.
//   load(bytes, len)        -> new object decoded from a CDR stream, or null
//   free(obj)
//   encode(obj, out, cap)   -> bytes written (header included), 0 on failure
//   size(obj)               -> exact serialized size (header included)
//   decode(obj, bytes, len) -> 1 on success; decodes into the existing object,
//                              reusing its allocations as a subscriber would
struct FcdrKind {
    void* (*load)(const uint8_t*, size_t);
    void (*free)(void*);
    size_t (*encode)(const void*, uint8_t*, size_t);
    size_t (*size)(const void*);
    int (*decode)(void*, const uint8_t*, size_t);
};

namespace {
template <class T> struct Ops {
    static void* load(const uint8_t* bytes, size_t len) {
        T* m = new (std::nothrow) T();
        if (m != nullptr && !decode_into(*m, bytes, len)) {
            delete m;
            m = nullptr;
        }
        return m;
    }
    static void free(void* m) { delete static_cast<T*>(m); }
    static size_t encode(const void* m, uint8_t* out, size_t cap) {
        return ::encode(*static_cast<const T*>(m), out, cap);
    }
    static size_t size(const void* m) { return 4 + ::size(0, *static_cast<const T*>(m)); }
    static int decode(void* m, const uint8_t* bytes, size_t len) {
        return decode_into(*static_cast<T*>(m), bytes, len) ? 1 : 0;
    }
};
}  // namespace

#define FASTCDR_EXPORT(NAME, TYPE)      \
    extern "C" const FcdrKind NAME = {  \
        &Ops<TYPE>::load,               \
        &Ops<TYPE>::free,               \
        &Ops<TYPE>::encode,             \
        &Ops<TYPE>::size,               \
        &Ops<TYPE>::decode,             \
    };

FASTCDR_EXPORT(fcdr_header, Header)
FASTCDR_EXPORT(fcdr_point_cloud2, PointCloud2)
FASTCDR_EXPORT(fcdr_image, Image)
FASTCDR_EXPORT(fcdr_joint_state, JointState)
FASTCDR_EXPORT(fcdr_pose_array, PoseArray)
FASTCDR_EXPORT(fcdr_string_list, StringList)
FASTCDR_EXPORT(fcdr_stamped_values, StampedValues)
