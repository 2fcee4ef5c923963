// glTF 2.0 loader: tinygltf parses the file, this reads and checks the default scene and hands
// its parts to scene/build.c, which makes the pn_scene (one world-space indexed triangle list, a
// draw per primitive instance, materials, RGBA8 textures, the first perspective camera). The
// project's only C++ file; nothing C++ crosses its boundary: every exception is caught here.
// Its length is the project's fixed choice of one C++ file for tinygltf: every glTF check
// (the file, accessors, nodes, materials, images, cameras, lights) lives behind that one C function.
//
// tinygltf checks the JSON structure but not the binary layout, so everything read from a buffer
// is validated here first, in 64-bit arithmetic, against counts a hostile file may make up.
#include <tiny_gltf.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

extern "C" {
#include "core/log.h"
#include "scene/anim.h"
#include "scene/build.h"
#include "scene/scene.h"
}

namespace {

// Output limits (build.h): refused here, before anything is decoded, with the accessor named.
constexpr uint64_t kMaxVertices = PN_SCENE_MAX_VERTICES;
constexpr uint64_t kMaxIndices = PN_SCENE_MAX_INDICES;
// An accessor without a bufferView is all zeros (plus sparse values): no data bounds its count.
constexpr uint64_t kMaxUnbackedCount = 1ull << 24;
// Node graphs are trees; a deeper one is not a scene anybody made by hand or by an exporter.
constexpr uint32_t kMaxDepth = 1024;
// tinygltf's error strings can quote a whole data: URI; keep log lines readable.
constexpr size_t kMaxMessage = 400;
constexpr double kPi = 3.14159265358979323846;

constexpr int kU8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
constexpr int kI8 = TINYGLTF_COMPONENT_TYPE_BYTE;
constexpr int kU16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
constexpr int kI16 = TINYGLTF_COMPONENT_TYPE_SHORT;
constexpr int kU32 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
constexpr int kF32 = TINYGLTF_COMPONENT_TYPE_FLOAT;

// Thrown after the message has been logged; carries the result code to return.
struct Failure {
    pn_result result;
};

// Column-major 4x4, m[col * 4 + row], as glTF stores node.matrix.
struct Mat4 {
    double m[16];
};

Mat4 mat_identity()
{
    Mat4 r{};
    r.m[0] = r.m[5] = r.m[10] = r.m[15] = 1.0;
    return r;
}

Mat4 mat_mul(const Mat4 &a, const Mat4 &b)
{
    Mat4 r{};
    pn_mat4_mul(a.m, b.m, r.m); // scene/anim.c: pn_scene_pose multiplies the same way
    return r;
}

inline bool finite3(const double v[3])
{
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

uint64_t component_size(int type)
{
    switch (type) {
    case kU8:
    case kI8: return 1;
    case kU16:
    case kI16: return 2;
    case kU32:
    case kF32: return 4;
    default: return 0;
    }
}

const char *component_name(int type)
{
    switch (type) {
    case kU8: return "unsigned byte";
    case kI8: return "byte";
    case kU16: return "unsigned short";
    case kI16: return "short";
    case kU32: return "unsigned int";
    case kF32: return "float";
    case TINYGLTF_COMPONENT_TYPE_INT: return "int";
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return "double";
    default: return "unknown";
    }
}

const char *type_name(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "unknown";
    }
}

int type_components(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;
    }
}

// One component as a float, with glTF's normalisation rules for integer types.
inline float read_component(const uint8_t *p, int type, bool normalized)
{
    switch (type) {
    case kF32: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
    }
    case kU8: return normalized ? (float)p[0] / 255.0f : (float)p[0];
    case kI8: {
        int8_t v;
        std::memcpy(&v, p, 1);
        return normalized ? std::fmax((float)v / 127.0f, -1.0f) : (float)v;
    }
    case kU16: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? (float)v / 65535.0f : (float)v;
    }
    case kI16: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::fmax((float)v / 32767.0f, -1.0f) : (float)v;
    }
    case kU32: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return (float)v;
    }
    default: return 0.0f;
    }
}

inline uint32_t read_index(const uint8_t *p, int type)
{
    switch (type) {
    case kU8: return p[0];
    case kU16: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
    }
    default: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
    }
    }
}

// Collapses a multi-line tinygltf message into one bounded line.
std::string one_line(const std::string &s)
{
    std::string r;
    bool sep = false; // a line break is pending: emit "; " before the next text
    for (char ch : s) {
        if (ch == '\n' || ch == '\r') {
            sep = !r.empty();
            continue;
        }
        if (sep) {
            while (!r.empty() && (r.back() == ' ' || r.back() == '.' || r.back() == ';'))
                r.pop_back();
            r += "; ";
            sep = false;
        }
        r += (unsigned char)ch < 0x20 ? ' ' : ch;
    }
    while (!r.empty() && (r.back() == ' ' || r.back() == ';' || r.back() == '.'))
        r.pop_back();
    if (r.size() > kMaxMessage) {
        r.resize(kMaxMessage);
        r += "...";
    }
    return r;
}

// Wraps tinygltf's stb_image decoder so that an undecodable image becomes an empty one (the
// texture is then dropped with a warning) instead of failing the whole file, and so that an
// image's bufferView is range-checked first: tinygltf 2.7 passes &buffer.data[byteOffset] and
// byteLength to the decoder without checking them against the buffer.
bool load_image_lenient(tinygltf::Image *image, const int image_idx, std::string *err,
                        std::string *warn, int req_width, int req_height,
                        const unsigned char *bytes, int size, void *user_data)
{
    (void)err;
    const tinygltf::Model *model = static_cast<const tinygltf::Model *>(user_data);
    std::string tag = "image " + std::to_string(image_idx);
    if (image->bufferView >= 0 && model) {
        bool ok = false;
        if ((size_t)image->bufferView < model->bufferViews.size()) {
            const tinygltf::BufferView &bv = model->bufferViews[(size_t)image->bufferView];
            if (bv.buffer >= 0 && (size_t)bv.buffer < model->buffers.size()) {
                size_t have = model->buffers[(size_t)bv.buffer].data.size();
                ok = bv.byteLength <= have && bv.byteOffset <= have - bv.byteLength &&
                     bv.byteLength <= (size_t)INT32_MAX;
            }
        }
        if (!ok) {
            if (warn)
                *warn += tag + ": bufferView " + std::to_string(image->bufferView) +
                         " is not inside its buffer; texture ignored\n";
            return true;
        }
    }
    if (!bytes || size <= 0) {
        if (warn)
            *warn += tag + ": no image data; texture ignored\n";
        return true;
    }
    std::string decode_err;
    bool ok = tinygltf::LoadImageData(image, image_idx, &decode_err, warn, req_width, req_height,
                                      bytes, size, nullptr);
    if (!ok) {
        image->image.clear();
        if (warn)
            *warn += tag + ": " + one_line(decode_err) + "; texture ignored\n";
    }
    return true;
}

bool ends_with_ci(const char *s, const char *suffix)
{
    size_t n = std::strlen(s), m = std::strlen(suffix);
    if (n < m)
        return false;
    for (size_t i = 0; i < m; i++) {
        char a = s[n - m + i], b = suffix[i];
        if (a >= 'A' && a <= 'Z')
            a = (char)(a - 'A' + 'a');
        if (a != b)
            return false;
    }
    return true;
}

// A validated accessor: `data` points at element 0 and every element i lies in
// [data + i * stride, data + i * stride + elem_size) inside its buffer.
struct Access {
    int index;
    const char *role;
    const tinygltf::Accessor *acc;
    const uint8_t *data; // nullptr: no bufferView, elements are zero (before sparse values)
    uint64_t stride;
    uint64_t count;
    uint64_t elem_size;
    int ctype;
    int ncomp;
};

class Loader {
public:
    Loader(const char *path, const tinygltf::Model &model) : path_(path), m_(model) {}
    ~Loader()
    {
        pn_scene_build_destroy(&b_);
        pn_scene_anim_destroy(anim_);
    }
    Loader(const Loader &) = delete;
    Loader &operator=(const Loader &) = delete;

    void run();
    void emit(pn_scene *out);

private:
    [[noreturn]] void fail(pn_result r, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
    void warn(const char *fmt, ...) __attribute__((format(printf, 2, 3)));

    std::string mesh_tag(int mesh) const;
    const uint8_t *view_bytes(int view, uint64_t offset, uint64_t need, int acc, const char *role,
                              const char *what);
    Access access(int index, const char *role, int type, std::initializer_list<int> ctypes);
    void decode_floats(const Access &a, std::vector<float> &out);
    void decode_indices(const Access &a, std::vector<uint32_t> &out);
    template <typename Fn> void apply_sparse(const Access &a, Fn write);

    Mat4 local_transform(int node);
    void read_animations();
    void keep_local(const pn_scene_build_prim &p, uint32_t first_vertex, bool mirrored);
    void finish_animations();
    void traverse();
    void visit_camera(int node, const Mat4 &world);
    void visit_light(int node, const Mat4 &world);
    void visit_punctual(int node, const tinygltf::Value &ext, const Mat4 &world);
    void instance_mesh(int mesh, const Mat4 &world);
    void instance_primitive(int mesh, int prim, const pn_scene_xform &xf);
    void built(pn_result r); // throws on PN_ERR_MEMORY, the one error the builder's appends have
    uint32_t material_for(int mesh, int material);
    void build_materials();
    int32_t texture_for(int material, const tinygltf::TextureInfo &info);

    const char *path_;
    const tinygltf::Model &m_;

    pn_scene_build b_{}; // the scene so far; b_.scene's camera and lights are set here directly
    std::vector<int32_t> image_texture_; // glTF image -> index in the textures, -1 none, -2 unseen
    bool default_material_used_ = false;
    // Instancing (pn_scene.meshes, .objects): each glTF mesh's local triangles, captured at its
    // first instance, and every instance.
    std::vector<int32_t> mesh_index_; // glTF mesh -> index in the scene's meshes, -1 not yet instanced
    int64_t capture_ = -1; // the scene mesh instance_primitive captures local triangles into, or -1

    std::vector<uint8_t> mesh_warned_; // bit flags per mesh, so instancing does not repeat them
    std::vector<uint8_t> camera_warned_;
    bool warned_skin_ = false;

    // Animations (scene/anim.h): with any, anim_ holds the nodes' rest transforms and parents, the
    // lights' and the camera's nodes; channels_ and prims_ (their arrays owned here until emitted)
    // what the animations move. targeted_: per node, an animation targets it.
    pn_scene_anim *anim_ = nullptr;
    struct KeptChannel {
        pn_anim_channel channel; // its arrays pointed at when emitted
        std::vector<float> times, values;
    };
    struct KeptPrim {
        pn_anim_prim prim; // likewise
        std::vector<float> pos, nrm, uv;
        std::vector<uint32_t> tri;
    };
    std::vector<KeptChannel> channels_;
    std::vector<KeptPrim> prims_;
    std::vector<uint8_t> targeted_;
    int cur_node_ = -1;     // the node whose mesh is being instanced
    bool cur_posed_ = false; // and whether an animation reaches it

    // What was skipped, to say why a scene ends up without triangles.
    uint64_t mesh_instances_ = 0, skipped_points_lines_ = 0, skipped_no_position_ = 0,
             skipped_empty_ = 0;

    // scratch, reused across primitives
    std::vector<float> pos_, nrm_, uv_;
    std::vector<uint32_t> idx_, tri_;
    std::vector<uint8_t> bad_normal_;
};

enum MeshWarning : uint8_t {
    kWarnNonTriangles = 1,
    kWarnNoPosition = 2,
    kWarnTrailing = 4,
    kWarnMaterial = 8,
    kWarnMorph = 16,
};

void Loader::fail(pn_result r, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pn_error("%s: %s", path_, msg);
    throw Failure{r};
}

void Loader::warn(const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pn_warn("%s: %s", path_, msg);
}

void Loader::built(pn_result r)
{
    if (r == PN_ERR_MEMORY)
        throw std::bad_alloc();
    assert(r == PN_OK);
}

std::string Loader::mesh_tag(int mesh) const
{
    std::string s = "mesh " + std::to_string(mesh);
    const std::string &name = m_.meshes[(size_t)mesh].name;
    if (!name.empty())
        s += " ('" + (name.size() > 64 ? name.substr(0, 64) + "..." : name) + "')";
    return s;
}

// Bytes [offset, offset + need) of bufferView `view`, after checking that the view lies inside its
// buffer and the range inside the view.
const uint8_t *Loader::view_bytes(int view, uint64_t offset, uint64_t need, int acc,
                                  const char *role, const char *what)
{
    if (view < 0 || (size_t)view >= m_.bufferViews.size())
        fail(PN_ERR_FORMAT, "accessor %d (%s): %sbufferView %d does not exist (%zu bufferViews)",
             acc, role, what, view, m_.bufferViews.size());
    const tinygltf::BufferView &bv = m_.bufferViews[(size_t)view];
    if (bv.buffer < 0 || (size_t)bv.buffer >= m_.buffers.size())
        fail(PN_ERR_FORMAT, "bufferView %d: buffer %d does not exist (%zu buffers)", view,
             bv.buffer, m_.buffers.size());
    uint64_t have = m_.buffers[(size_t)bv.buffer].data.size();
    uint64_t vlen = bv.byteLength, voff = bv.byteOffset;
    if (vlen > have || voff > have - vlen)
        fail(PN_ERR_FORMAT,
             "bufferView %d: bytes %llu..%llu+%llu exceed buffer %d (%llu bytes)", view,
             (unsigned long long)voff, (unsigned long long)voff, (unsigned long long)vlen,
             bv.buffer, (unsigned long long)have);
    if (offset > vlen || need > vlen - offset)
        fail(PN_ERR_FORMAT,
             "accessor %d (%s): %s%llu bytes at byteOffset %llu exceed bufferView %d (%llu bytes)",
             acc, role, what, (unsigned long long)need, (unsigned long long)offset, view,
             (unsigned long long)vlen);
    return m_.buffers[(size_t)bv.buffer].data.data() + voff + offset;
}

Access Loader::access(int index, const char *role, int type, std::initializer_list<int> ctypes)
{
    if (index < 0 || (size_t)index >= m_.accessors.size())
        fail(PN_ERR_FORMAT, "%s accessor %d does not exist (%zu accessors)", role, index,
             m_.accessors.size());
    const tinygltf::Accessor &acc = m_.accessors[(size_t)index];
    bool ctype_ok = false;
    for (int c : ctypes)
        ctype_ok |= acc.componentType == c;
    if (acc.type != type || !ctype_ok) {
        std::string want;
        for (int c : ctypes)
            want += std::string(want.empty() ? "" : " or ") + component_name(c);
        fail(PN_ERR_FORMAT, "accessor %d (%s): %s %s is not supported (expected %s %s)", index,
             role, type_name(acc.type), component_name(acc.componentType), type_name(type),
             want.c_str());
    }
    Access a{};
    a.index = index;
    a.role = role;
    a.acc = &acc;
    a.ctype = acc.componentType;
    a.ncomp = type_components(type);
    a.elem_size = component_size(a.ctype) * (uint64_t)a.ncomp;
    a.count = acc.count;
    if (a.count == 0)
        fail(PN_ERR_FORMAT, "accessor %d (%s): count is 0", index, role);
    if (acc.bufferView == -1) {
        if (a.count > kMaxUnbackedCount)
            fail(PN_ERR_FORMAT,
                 "accessor %d (%s): count %llu without a bufferView exceeds the limit of %llu",
                 index, role, (unsigned long long)a.count, (unsigned long long)kMaxUnbackedCount);
        a.data = nullptr;
        a.stride = a.elem_size;
        return a;
    }
    if (acc.bufferView < 0 || (size_t)acc.bufferView >= m_.bufferViews.size())
        fail(PN_ERR_FORMAT, "accessor %d (%s): bufferView %d does not exist (%zu bufferViews)",
             index, role, acc.bufferView, m_.bufferViews.size());
    const tinygltf::BufferView &bv = m_.bufferViews[(size_t)acc.bufferView];
    a.stride = bv.byteStride ? (uint64_t)bv.byteStride : a.elem_size;
    if (a.stride < a.elem_size)
        fail(PN_ERR_FORMAT, "accessor %d (%s): byteStride %llu is smaller than an element (%llu)",
             index, role, (unsigned long long)a.stride, (unsigned long long)a.elem_size);
    // need = stride * (count - 1) + elem_size, saturating: any overflow exceeds every view.
    uint64_t need;
    if (__builtin_mul_overflow(a.stride, a.count - 1, &need) ||
        __builtin_add_overflow(need, a.elem_size, &need))
        need = UINT64_MAX;
    if (need == UINT64_MAX || acc.byteOffset > UINT64_MAX - need ||
        (uint64_t)acc.byteOffset + need > (uint64_t)bv.byteLength)
        fail(PN_ERR_FORMAT,
             "accessor %d (%s): count %llu with stride %llu at byteOffset %llu exceeds "
             "bufferView %d (%llu bytes)",
             index, role, (unsigned long long)a.count, (unsigned long long)a.stride,
             (unsigned long long)acc.byteOffset, acc.bufferView,
             (unsigned long long)bv.byteLength);
    a.data = view_bytes(acc.bufferView, acc.byteOffset, need, index, role, "");
    return a;
}

// Validates the accessor's sparse block and calls write(element, bytes) for every substitution,
// `bytes` being one tightly packed element of the accessor's own component type.
template <typename Fn> void Loader::apply_sparse(const Access &a, Fn write)
{
    const auto &sp = a.acc->sparse;
    if (!sp.isSparse)
        return;
    if (sp.count < 1 || (uint64_t)sp.count > a.count)
        fail(PN_ERR_FORMAT, "accessor %d (%s): sparse count %d is not in 1..%llu", a.index,
             a.role, sp.count, (unsigned long long)a.count);
    int ictype = sp.indices.componentType;
    if (ictype != kU8 && ictype != kU16 && ictype != kU32)
        fail(PN_ERR_FORMAT, "accessor %d (%s): sparse indices of type %s are not supported",
             a.index, a.role, component_name(ictype));
    if (sp.indices.byteOffset < 0 || sp.values.byteOffset < 0)
        fail(PN_ERR_FORMAT, "accessor %d (%s): negative sparse byteOffset", a.index, a.role);
    uint64_t n = (uint64_t)sp.count, isize = component_size(ictype);
    const uint8_t *ip = view_bytes(sp.indices.bufferView, (uint64_t)sp.indices.byteOffset,
                                   n * isize, a.index, a.role, "sparse indices: ");
    const uint8_t *vp = view_bytes(sp.values.bufferView, (uint64_t)sp.values.byteOffset,
                                   n * a.elem_size, a.index, a.role, "sparse values: ");
    for (uint64_t k = 0; k < n; k++) {
        uint32_t e = read_index(ip + k * isize, ictype);
        if (e >= a.count)
            fail(PN_ERR_FORMAT, "accessor %d (%s): sparse index %u >= count %llu", a.index,
                 a.role, e, (unsigned long long)a.count);
        write(e, vp + k * a.elem_size);
    }
}

void Loader::decode_floats(const Access &a, std::vector<float> &out)
{
    const uint64_t nc = (uint64_t)a.ncomp;
    out.assign(a.count * nc, 0.0f);
    const uint64_t csize = component_size(a.ctype);
    const bool norm = a.acc->normalized;
    if (a.data) {
        if (a.ctype == kF32 && a.stride == a.elem_size) {
            std::memcpy(out.data(), a.data, a.count * a.elem_size);
        } else if (a.ctype == kF32) {
            for (uint64_t i = 0; i < a.count; i++)
                std::memcpy(&out[i * nc], a.data + i * a.stride, a.elem_size);
        } else {
            for (uint64_t i = 0; i < a.count; i++)
                for (uint64_t c = 0; c < nc; c++)
                    out[i * nc + c] = read_component(a.data + i * a.stride + c * csize, a.ctype,
                                                     norm);
        }
    }
    apply_sparse(a, [&](uint32_t e, const uint8_t *src) {
        for (uint64_t c = 0; c < nc; c++)
            out[e * nc + c] = read_component(src + c * csize, a.ctype, norm);
    });
}

void Loader::decode_indices(const Access &a, std::vector<uint32_t> &out)
{
    out.assign(a.count, 0u);
    if (a.data) {
        if (a.ctype == kU32 && a.stride == 4) {
            std::memcpy(out.data(), a.data, a.count * 4);
        } else {
            for (uint64_t i = 0; i < a.count; i++)
                out[i] = read_index(a.data + i * a.stride, a.ctype);
        }
    }
    apply_sparse(a, [&](uint32_t e, const uint8_t *src) { out[e] = read_index(src, a.ctype); });
}

Mat4 Loader::local_transform(int index)
{
    const tinygltf::Node &n = m_.nodes[(size_t)index];
    Mat4 r = mat_identity();
    if (!n.matrix.empty()) {
        if (n.matrix.size() != 16)
            fail(PN_ERR_FORMAT, "node %d: matrix has %zu numbers, not 16", index,
                 n.matrix.size());
        for (int i = 0; i < 16; i++)
            r.m[i] = n.matrix[(size_t)i];
    } else {
        if ((!n.translation.empty() && n.translation.size() != 3) ||
            (!n.rotation.empty() && n.rotation.size() != 4) ||
            (!n.scale.empty() && n.scale.size() != 3))
            fail(PN_ERR_FORMAT,
                 "node %d: translation/rotation/scale have %zu/%zu/%zu numbers, not 3/4/3", index,
                 n.translation.size(), n.rotation.size(), n.scale.size());
        double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
        for (int i = 0; i < 3 && !n.translation.empty(); i++)
            t[i] = n.translation[(size_t)i];
        for (int i = 0; i < 4 && !n.rotation.empty(); i++)
            q[i] = n.rotation[(size_t)i];
        for (int i = 0; i < 3 && !n.scale.empty(); i++)
            s[i] = n.scale[(size_t)i];
        // glTF requires a unit quaternion; exporters round, so renormalise rather than shear
        // (pn_trs_matrix, which pn_scene_pose uses too).
        if (!pn_trs_matrix(t, q, s, r.m))
            fail(PN_ERR_FORMAT, "node %d: rotation quaternion is zero or not finite", index);
        if (anim_) {
            pn_anim_node &an = anim_->nodes[(size_t)index];
            std::memcpy(an.t, t, sizeof an.t), std::memcpy(an.r, q, sizeof an.r), std::memcpy(an.s, s, sizeof an.s);
        }
    }
    if (anim_ && !n.matrix.empty()) {
        anim_->nodes[(size_t)index].matrix = true;
        std::memcpy(anim_->nodes[(size_t)index].m, r.m, sizeof r.m);
    }
    for (double v : r.m)
        if (!std::isfinite(v))
            fail(PN_ERR_FORMAT, "node %d: transform is not finite", index);
    return r;
}

// glTF animations: every channel that moves a node's translation, rotation or scale, checked
// (the sampler and node exist, the node is not given as a matrix, key times finite and strictly
// increasing, as many values as keys, every value finite, no zero rotation) and kept with its keys.
// A file with animations also keeps its nodes (anim_) so that the scene can be posed again.
// Morph-target weights are not drawn: their channels are skipped with a warning.
void Loader::read_animations()
{
    if (m_.animations.empty())
        return;
    anim_ = (pn_scene_anim *)std::calloc(1, sizeof *anim_);
    const size_t nn = m_.nodes.size();
    if (!anim_ || !(anim_->nodes = (pn_anim_node *)std::calloc(nn ? nn : 1, sizeof *anim_->nodes)) ||
        !(anim_->order = (uint32_t *)std::calloc(nn ? nn : 1, sizeof *anim_->order)))
        throw std::bad_alloc();
    anim_->node_count = (uint32_t)nn;
    for (size_t i = 0; i < nn; i++) {
        pn_anim_node &n = anim_->nodes[i];
        n.parent = -1;
        n.r[3] = 1, n.s[0] = n.s[1] = n.s[2] = 1;
    }
    for (int &l : anim_->light_node)
        l = -1;
    anim_->camera_node = -1;
    targeted_.assign(nn, 0);
    bool warned_weights = false;
    for (size_t ai = 0; ai < m_.animations.size(); ai++) {
        const tinygltf::Animation &an = m_.animations[ai];
        for (size_t ci = 0; ci < an.channels.size(); ci++) {
            const tinygltf::AnimationChannel &ch = an.channels[ci];
            char where[96];
            std::snprintf(where, sizeof where, "animation %zu channel %zu", ai, ci);
            if (ch.sampler < 0 || (size_t)ch.sampler >= an.samplers.size())
                fail(PN_ERR_FORMAT, "%s: sampler %d does not exist (%zu samplers)", where, ch.sampler,
                     an.samplers.size());
            if (ch.target_node < 0 || (size_t)ch.target_node >= nn)
                fail(PN_ERR_FORMAT, "%s: target node %d does not exist (%zu nodes)", where, ch.target_node, nn);
            pn_anim_path path;
            if (ch.target_path == "translation")
                path = PN_ANIM_TRANSLATION;
            else if (ch.target_path == "rotation")
                path = PN_ANIM_ROTATION;
            else if (ch.target_path == "scale")
                path = PN_ANIM_SCALE;
            else if (ch.target_path == "weights") {
                if (!warned_weights)
                    warn("%s: morph target weights are not animated (morph targets are not drawn); skipped", where);
                warned_weights = true;
                continue;
            } else
                fail(PN_ERR_FORMAT, "%s: target path \"%.32s\" is not translation, rotation, scale or weights", where,
                     ch.target_path.c_str());
            if (!m_.nodes[(size_t)ch.target_node].matrix.empty())
                fail(PN_ERR_FORMAT, "%s: node %d is given as a matrix, which glTF does not let an animation target",
                     where, ch.target_node);
            const tinygltf::AnimationSampler &sm = an.samplers[(size_t)ch.sampler];
            KeptChannel k{};
            k.channel.node = (uint32_t)ch.target_node;
            k.channel.path = path;
            if (sm.interpolation == "LINEAR" || sm.interpolation.empty())
                k.channel.interp = PN_ANIM_LINEAR;
            else if (sm.interpolation == "STEP")
                k.channel.interp = PN_ANIM_STEP;
            else if (sm.interpolation == "CUBICSPLINE")
                k.channel.interp = PN_ANIM_CUBICSPLINE;
            else
                fail(PN_ERR_FORMAT, "%s: sampler %d: interpolation \"%.32s\" is not LINEAR, STEP or CUBICSPLINE", where,
                     ch.sampler, sm.interpolation.c_str());
            decode_floats(access(sm.input, "animation input", TINYGLTF_TYPE_SCALAR, {kF32}), k.times);
            if (k.times.empty())
                fail(PN_ERR_FORMAT, "%s: sampler %d has no keys", where, ch.sampler);
            for (size_t i = 0; i < k.times.size(); i++) {
                if (!std::isfinite(k.times[i]))
                    fail(PN_ERR_FORMAT, "%s: sampler %d: key time %zu is not finite", where, ch.sampler, i);
                if (i && !(k.times[i] > k.times[i - 1]))
                    fail(PN_ERR_FORMAT, "%s: sampler %d: key times are not strictly increasing (key %zu at %g after %g)",
                         where, ch.sampler, i, (double)k.times[i], (double)k.times[i - 1]);
            }
            bool rot = path == PN_ANIM_ROTATION;
            const char *role = rot ? "animation rotation" : "animation output";
            if (rot)
                decode_floats(access(sm.output, role, TINYGLTF_TYPE_VEC4, {kF32, kI8, kU8, kI16, kU16}), k.values);
            else
                decode_floats(access(sm.output, role, TINYGLTF_TYPE_VEC3, {kF32}), k.values);
            const size_t w = rot ? 4 : 3, per_key = k.channel.interp == PN_ANIM_CUBICSPLINE ? 3 : 1;
            if (k.values.size() != k.times.size() * w * per_key)
                fail(PN_ERR_FORMAT, "%s: sampler %d: %zu values for %zu keys (%s needs %zu per key)", where,
                     ch.sampler, k.values.size() / w, k.times.size(), sm.interpolation.c_str(), per_key);
            for (size_t i = 0; i < k.values.size(); i++)
                if (!std::isfinite(k.values[i]))
                    fail(PN_ERR_FORMAT, "%s: sampler %d: value %zu is not finite", where, ch.sampler, i / w);
            for (size_t i = 0; rot && i < k.times.size(); i++) {
                const float *q = &k.values[(i * per_key + (per_key == 3 ? 1 : 0)) * 4];
                if (!(std::fabs(q[0]) + std::fabs(q[1]) + std::fabs(q[2]) + std::fabs(q[3]) > 0))
                    fail(PN_ERR_FORMAT, "%s: sampler %d: rotation key %zu is zero", where, ch.sampler, i);
            }
            k.channel.keys = (uint32_t)k.times.size();
            targeted_[(size_t)ch.target_node] = 1;
            channels_.push_back(std::move(k));
        }
    }
}

// Hands the kept channels and primitives to anim_ as the C arrays pn_scene_anim_destroy frees.
void Loader::finish_animations()
{
    if (!anim_)
        return;
    auto copy = [](const void *src, size_t bytes) {
        void *p = std::malloc(bytes ? bytes : 1);
        if (!p)
            throw std::bad_alloc();
        if (bytes)
            std::memcpy(p, src, bytes);
        return p;
    };
    anim_->channels = (pn_anim_channel *)std::calloc(channels_.size() ? channels_.size() : 1, sizeof *anim_->channels);
    anim_->prims = (pn_anim_prim *)std::calloc(prims_.size() ? prims_.size() : 1, sizeof *anim_->prims);
    if (!anim_->channels || !anim_->prims)
        throw std::bad_alloc();
    anim_->start = INFINITY, anim_->end = -INFINITY;
    for (KeptChannel &k : channels_) {
        pn_anim_channel &c = anim_->channels[anim_->channel_count++];
        c = k.channel;
        c.times = (float *)copy(k.times.data(), k.times.size() * sizeof(float));
        c.values = (float *)copy(k.values.data(), k.values.size() * sizeof(float));
        anim_->start = std::fmin(anim_->start, (double)k.times.front());
        anim_->end = std::fmax(anim_->end, (double)k.times.back());
    }
    if (!anim_->channel_count)
        anim_->start = anim_->end = 0;
    for (KeptPrim &k : prims_) {
        pn_anim_prim &p = anim_->prims[anim_->prim_count++];
        p = k.prim;
        p.positions = (float *)copy(k.pos.data(), k.pos.size() * sizeof(float));
        p.normals = k.nrm.empty() ? nullptr : (float *)copy(k.nrm.data(), k.nrm.size() * sizeof(float));
        p.uvs = k.uv.empty() ? nullptr : (float *)copy(k.uv.data(), k.uv.size() * sizeof(float));
        p.triangles = (uint32_t *)copy(k.tri.data(), k.tri.size() * sizeof(uint32_t));
    }
    channels_.clear();
    prims_.clear();
}

void Loader::run()
{
    // tinygltf reads glTF 1.0 files without complaint and finds nothing in them.
    const std::string &version = m_.asset.version;
    if (version.compare(0, 2, "2.") != 0)
        fail(PN_ERR_FORMAT, "glTF version \"%.16s\" is not supported (2.x required)",
             version.c_str());
    for (const std::string &ext : m_.extensionsRequired) {
        if (ext == "KHR_lights_punctual")
            continue; // read (visit_punctual)
        if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" ||
            ext == "KHR_mesh_quantization")
            fail(PN_ERR_FORMAT, "requires extension %s, which is not supported", ext.c_str());
        warn("requires extension %s, which is not supported; ignoring it", ext.c_str());
    }
    mesh_warned_.assign(m_.meshes.size(), 0);
    mesh_index_.assign(m_.meshes.size(), -1);
    camera_warned_.assign(m_.cameras.size(), 0);
    image_texture_.assign(m_.images.size(), -2);
    build_materials();
    read_animations();
    traverse();
    finish_animations();
    if (b_.scene.index_count == 0) {
        std::string why;
        if (m_.meshes.empty()) {
            why = "the file has no meshes";
        } else if (mesh_instances_ == 0) {
            why = "no node of the scene references a mesh";
        } else {
            auto add = [&](uint64_t n, const char *what) {
                if (n)
                    why += (why.empty() ? "" : ", ") + std::to_string(n) + what;
            };
            add(skipped_points_lines_, " point or line primitive(s) skipped");
            add(skipped_no_position_, " primitive(s) without POSITION skipped");
            add(skipped_empty_, " primitive(s) with fewer than 3 vertices");
            if (why.empty())
                why = "its meshes have no primitives";
        }
        fail(PN_ERR_FORMAT, "no triangles in the scene (%s)", why.c_str());
    }
}

// Depth-first, pre-order, children in file order, with an explicit stack so that a deep (or
// hostile) hierarchy cannot overflow the call stack. glTF nodes form trees: a node reached a
// second time means a cycle or a shared child, and is rejected rather than instanced again.
void Loader::traverse()
{
    const size_t nn = m_.nodes.size();
    std::vector<int> roots;
    if (!m_.scenes.empty()) {
        int s = m_.defaultScene >= 0 ? m_.defaultScene : 0;
        if ((size_t)s >= m_.scenes.size())
            fail(PN_ERR_FORMAT, "default scene %d does not exist (%zu scenes)", s,
                 m_.scenes.size());
        roots = m_.scenes[(size_t)s].nodes;
    } else {
        std::vector<uint8_t> is_child(nn, 0);
        for (const tinygltf::Node &n : m_.nodes)
            for (int c : n.children)
                if (c >= 0 && (size_t)c < nn)
                    is_child[(size_t)c] = 1;
        for (size_t i = 0; i < nn; i++)
            if (!is_child[i])
                roots.push_back((int)i);
        if (roots.empty() && nn)
            fail(PN_ERR_FORMAT, "no scenes and no root nodes (the node graph is cyclic)");
    }
    struct Item {
        int node;
        uint32_t depth;
        Mat4 parent;
        int parent_node; // -1 for a root
        bool posed;      // an animation reaches the parent
    };
    std::vector<uint8_t> visited(nn, 0);
    std::vector<Item> stack;
    for (size_t i = roots.size(); i-- > 0;)
        stack.push_back(Item{roots[i], 0, mat_identity(), -1, false});
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        if (it.node < 0 || (size_t)it.node >= nn)
            fail(PN_ERR_FORMAT, "node %d does not exist (%zu nodes)", it.node, nn);
        if (visited[(size_t)it.node])
            fail(PN_ERR_FORMAT,
                 "node %d is reached twice (a cycle or a node with two parents)", it.node);
        visited[(size_t)it.node] = 1;
        if (it.depth > kMaxDepth)
            fail(PN_ERR_FORMAT, "node hierarchy deeper than %u levels", kMaxDepth);
        const tinygltf::Node &n = m_.nodes[(size_t)it.node];
        Mat4 world = mat_mul(it.parent, local_transform(it.node));
        bool posed = it.posed || (anim_ && targeted_[(size_t)it.node]);
        if (anim_) {
            anim_->nodes[(size_t)it.node].parent = it.parent_node;
            anim_->nodes[(size_t)it.node].posed = posed;
            anim_->order[anim_->order_count++] = (uint32_t)it.node;
        }
        cur_node_ = it.node;
        cur_posed_ = posed;
        if (n.camera != -1)
            visit_camera(it.node, world);
        if (n.extras.IsObject() && n.extras.Has("penumbra_light"))
            visit_light(it.node, world);
        auto punctual = n.extensions.find("KHR_lights_punctual");
        if (punctual != n.extensions.end())
            visit_punctual(it.node, punctual->second, world);
        if (n.skin != -1 && !warned_skin_) {
            warned_skin_ = true;
            warn("skinning is not supported; skinned meshes are drawn in their bind pose");
        }
        if (n.mesh != -1) {
            if (n.mesh < 0 || (size_t)n.mesh >= m_.meshes.size())
                fail(PN_ERR_FORMAT, "node %d: mesh %d does not exist (%zu meshes)", it.node,
                     n.mesh, m_.meshes.size());
            mesh_instances_++;
            pn_scene_object o{};
            o.node = (uint32_t)it.node;
            o.first_index = b_.scene.index_count;
            o.first_vertex = b_.scene.vertex_count;
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++)
                    o.to_world[r][c] = (float)world.m[c * 4 + r];
                o.to_world[r][3] = (float)world.m[12 + r];
            }
            instance_mesh(n.mesh, world);
            o.index_count = b_.scene.index_count - o.first_index;
            o.vertex_count = b_.scene.vertex_count - o.first_vertex;
            if (o.index_count) {
                o.mesh = (uint32_t)mesh_index_[(size_t)n.mesh];
                built(pn_scene_build_add_object(&b_, &o));
            }
        }
        for (size_t i = n.children.size(); i-- > 0;)
            stack.push_back(Item{n.children[i], it.depth + 1, world, it.node, posed});
    }
}

void Loader::visit_camera(int node, const Mat4 &w)
{
    int ci = m_.nodes[(size_t)node].camera;
    if (ci < 0 || (size_t)ci >= m_.cameras.size())
        fail(PN_ERR_FORMAT, "node %d: camera %d does not exist (%zu cameras)", node, ci,
             m_.cameras.size());
    if (b_.scene.has_camera)
        return;
    const tinygltf::Camera &cam = m_.cameras[(size_t)ci];
    if (cam.type != "perspective") {
        if (!camera_warned_[(size_t)ci]) {
            camera_warned_[(size_t)ci] = 1;
            warn("camera %d: %s cameras are not supported; ignored", ci,
                 cam.type == "orthographic" ? "orthographic" : "untyped");
        }
        return;
    }
    double yfov = cam.perspective.yfov;
    double pos[3], fwd[3], up[3]; // the node's origin, -Z axis and +Y axis (as pn_scene_pose has them)
    bool frame = pn_node_frame(w.m, pos, fwd, up);
    const char *problem = nullptr;
    if (!(yfov > 0.0 && yfov < kPi))
        problem = "yfov is not in (0, pi)";
    else if (!finite3(pos))
        problem = "position is not finite";
    // Stored as floats and used like scene positions: the same 1e18 limit (pn_scene_validate).
    else if (std::fabs(pos[0]) > 1e18 || std::fabs(pos[1]) > 1e18 || std::fabs(pos[2]) > 1e18)
        problem = "position is beyond 1e18 from the origin";
    else if (!frame)
        problem = "its node's transform is degenerate";
    if (problem) {
        if (!camera_warned_[(size_t)ci]) {
            camera_warned_[(size_t)ci] = 1;
            warn("camera %d: %s; ignored", ci, problem);
        }
        return;
    }
    pn_camera &camera = b_.scene.camera;
    b_.scene.has_camera = true;
    if (anim_)
        anim_->camera_node = node;
    for (int i = 0; i < 3; i++) {
        camera.pos[i] = (float)pos[i];
        camera.target[i] = (float)(pos[i] + fwd[i]);
        camera.up[i] = (float)up[i];
    }
    camera.yfov_deg = (float)(yfov * 180.0 / kPi);
}

// An area light on a node (glTF has no area-light extension): extras {"penumbra_light": {"size":
// [w, h], "radiance": r or [r, g, b]}}. The rectangle lies in the node's XY plane, centred on its
// origin, w along its X axis and h along Y (in the node's units, so the node's scale applies), and
// emits along the node's -Z axis (as glTF's cameras and punctual lights look). size [0, 0] is a
// point light. A malformed one is reported and ignored, like a camera.
void Loader::visit_light(int node, const Mat4 &w)
{
    const tinygltf::Value &v = m_.nodes[(size_t)node].extras.Get("penumbra_light");
    auto numbers = [](const tinygltf::Value &a, double *out, int n) {
        if (a.IsNumber() && n == 3) {
            out[0] = out[1] = out[2] = a.GetNumberAsDouble();
            return std::isfinite(out[0]);
        }
        if (!a.IsArray() || (int)a.ArrayLen() != n)
            return false;
        for (int i = 0; i < n; i++) {
            if (!a.Get(i).IsNumber())
                return false;
            out[i] = a.Get(i).GetNumberAsDouble();
            if (!std::isfinite(out[i]))
                return false;
        }
        return true;
    };
    double size[2], radiance[3];
    double pos[3] = {w.m[12], w.m[13], w.m[14]};
    double ax[3] = {w.m[0], w.m[1], w.m[2]}, ay[3] = {w.m[4], w.m[5], w.m[6]};
    double nrm[3] = {-w.m[8], -w.m[9], -w.m[10]};
    double sx = std::sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    double sy = std::sqrt(ay[0] * ay[0] + ay[1] * ay[1] + ay[2] * ay[2]);
    const char *problem = nullptr;
    if (!v.IsObject())
        problem = "penumbra_light is not an object";
    else if (!numbers(v.Get("size"), size, 2) || size[0] < 0 || size[1] < 0 || ((size[0] == 0) != (size[1] == 0)))
        problem = "size is not [width, height], both positive or both 0";
    else if (!numbers(v.Get("radiance"), radiance, 3) || radiance[0] < 0 || radiance[1] < 0 || radiance[2] < 0)
        problem = "radiance is not a non-negative number or [r, g, b]";
    else if (!finite3(pos) || std::fabs(pos[0]) > 1e18 || std::fabs(pos[1]) > 1e18 || std::fabs(pos[2]) > 1e18)
        problem = "its position is not finite or beyond 1e18 from the origin";
    else if (!pn_scene_unit3(nrm) || !pn_scene_unit3(ay) || !(sx > 0 && std::isfinite(sx)) || !(sy > 0 && std::isfinite(sy)))
        problem = "its node's transform is degenerate";
    else if (b_.scene.light_count == PN_SCENE_MAX_LIGHTS)
        problem = "more lights than the 16 a frame takes";
    if (problem) {
        warn("node %d: light ignored: %s", node, problem);
        return;
    }
    pn_light l{};
    for (int i = 0; i < 3; i++) {
        l.pos[i] = (float)pos[i];
        l.normal[i] = (float)nrm[i];
        l.up[i] = (float)ay[i];
        l.radiance[i] = (float)radiance[i];
    }
    l.size[0] = (float)(size[0] * sx);
    l.size[1] = (float)(size[1] * sy);
    b_.scene.lights[b_.scene.light_count++] = l;
}

// KHR_lights_punctual: a node's extension {"light": i} places light i of the file's list at the
// node's origin, shining along the node's -Z axis (spot, directional). The extension's units are
// kept, colour times intensity, without a conversion to watts: a point's or spot's candela is its
// intensity, a directional light's lux its irradiance on a plane facing it. Sizes come from the
// light's extras: "angular_diameter" in degrees for a directional light (default 0.53, the sun's;
// 0 is a hard directional light), "radius" for a point (0, the default, is a point; above 0 a sphere
// of that radius and the same intensity; a spot's radius is warned about and not drawn). A spot's
// cones shade with the extension's falloff, and a point's or spot's "range" with its window
// (pn_light_range_window). A malformed light is reported and skipped.
void Loader::visit_punctual(int node, const tinygltf::Value &ext, const Mat4 &w)
{
    const tinygltf::Value &index = ext.Get("light");
    if (!ext.IsObject() || !index.IsNumber()) {
        warn("node %d: KHR_lights_punctual without a light index; ignored", node);
        return;
    }
    double li = index.GetNumberAsDouble();
    if (!(li >= 0 && li < (double)m_.lights.size() && li == std::floor(li))) {
        warn("node %d: KHR_lights_punctual light %g does not exist (%zu lights); ignored", node, li, m_.lights.size());
        return;
    }
    const tinygltf::Light &src = m_.lights[(size_t)li];
    pn_light l{};
    double pos[3], dir[3], up[3]; // the node's origin, -Z axis and +Y (as pn_scene_pose has them)
    bool frame = pn_node_frame(w.m, pos, dir, up);
    double color[3] = {1, 1, 1};
    const char *problem = nullptr;
    auto extra = [&](const char *key, double fallback, double *out) {
        *out = fallback;
        if (!src.extras.IsObject() || !src.extras.Has(key))
            return true;
        const tinygltf::Value &x = src.extras.Get(key);
        *out = x.IsNumber() ? x.GetNumberAsDouble() : NAN;
        return std::isfinite(*out) && *out >= 0;
    };
    if (src.type == "directional")
        l.kind = PN_LIGHT_SUN;
    else if (src.type == "point" || src.type == "spot")
        l.kind = PN_LIGHT_OMNI;
    else
        problem = "its type is not directional, point or spot";
    if (!problem && !src.color.empty()) {
        if (src.color.size() != 3)
            problem = "its color is not 3 numbers";
        for (size_t k = 0; !problem && k < 3; k++)
            if (!(std::isfinite(src.color[k]) && src.color[k] >= 0))
                problem = "its color is not 3 finite non-negative numbers";
            else
                color[k] = src.color[k];
    }
    double diameter = 0, radius = 0;
    if (problem) {
    } else if (!(std::isfinite(src.intensity) && src.intensity >= 0))
        problem = "its intensity is not a finite non-negative number";
    else if (!finite3(pos) || std::fabs(pos[0]) > 1e18 || std::fabs(pos[1]) > 1e18 || std::fabs(pos[2]) > 1e18)
        problem = "its position is not finite or beyond 1e18 from the origin";
    else if (!frame)
        problem = "its node's transform is degenerate (no direction)";
    else if (l.kind == PN_LIGHT_SUN && !(extra("angular_diameter", 0.53, &diameter) && diameter <= 10))
        problem = "extras.angular_diameter is not a number of degrees in [0, 10]";
    else if (l.kind == PN_LIGHT_OMNI && !extra("radius", 0, &radius))
        problem = "extras.radius is not a finite non-negative number";
    else if (!(std::isfinite(src.range) && src.range >= 0))
        problem = "its range is not a positive number";
    else if (src.type == "spot" && !(src.spot.innerConeAngle >= 0 && src.spot.innerConeAngle < src.spot.outerConeAngle &&
                                     src.spot.outerConeAngle <= kPi / 2))
        problem = "its spot cones are not 0 <= innerConeAngle < outerConeAngle <= pi/2";
    else if (b_.scene.light_count == PN_SCENE_MAX_LIGHTS)
        problem = "more lights than the 16 a frame takes";
    if (problem) {
        warn("node %d: KHR_lights_punctual light %d ('%.64s') skipped: %s", node, (int)li, src.name.c_str(), problem);
        return;
    }
    // A point light with a radius is a sphere of the same intensity: I = pi r^2 L every way.
    double to_radiance = 1;
    if (radius > 0 && src.type == "point") {
        l.kind = PN_LIGHT_SPHERE;
        l.radius = (float)radius;
        to_radiance = 1 / (kPi * radius * radius);
    } else if (radius > 0) {
        warn("node %d: spot %d has radius %g: a spot with a size is not drawn yet; drawn as a point spot", node,
             (int)li, radius);
    }
    if (src.type != "directional" && src.range > 0)
        l.range = (float)src.range;
    for (int k = 0; k < 3; k++) {
        l.pos[k] = (float)pos[k];
        l.normal[k] = (float)dir[k];
        l.up[k] = (float)up[k];
        l.radiance[k] = (float)(color[k] * src.intensity * to_radiance);
    }
    l.angle = (float)(diameter * kPi / 180.0);
    if (src.type == "spot") {
        l.cone[0] = (float)src.spot.innerConeAngle;
        l.cone[1] = (float)src.spot.outerConeAngle;
    }
    if (anim_)
        anim_->light_node[b_.scene.light_count] = node;
    b_.scene.lights[b_.scene.light_count++] = l;
}

void Loader::instance_mesh(int mesh, const Mat4 &world)
{
    pn_scene_xform xf = pn_scene_xform_from_matrix(world.m);
    const tinygltf::Mesh &me = m_.meshes[(size_t)mesh];
    // The first instance also keeps the mesh's local triangles; the others produce the same ones.
    if (mesh_index_[(size_t)mesh] < 0) {
        uint32_t index;
        built(pn_scene_build_add_mesh(&b_, &index));
        mesh_index_[(size_t)mesh] = (int32_t)index;
        capture_ = index;
    }
    for (size_t p = 0; p < me.primitives.size(); p++)
        instance_primitive(mesh, (int)p, xf);
    capture_ = -1;
}

void Loader::instance_primitive(int mesh, int prim, const pn_scene_xform &xf)
{
    const tinygltf::Primitive &pr = m_.meshes[(size_t)mesh].primitives[(size_t)prim];
    uint8_t &warned = mesh_warned_[(size_t)mesh];
    int mode = pr.mode == -1 ? TINYGLTF_MODE_TRIANGLES : pr.mode;
    if (mode < TINYGLTF_MODE_POINTS || mode > TINYGLTF_MODE_TRIANGLE_FAN)
        fail(PN_ERR_FORMAT, "%s primitive %d: mode %d is not a glTF primitive mode",
             mesh_tag(mesh).c_str(), prim, pr.mode);
    if (mode < TINYGLTF_MODE_TRIANGLES) {
        skipped_points_lines_++;
        if (!(warned & kWarnNonTriangles)) {
            warned |= kWarnNonTriangles;
            warn("%s: point and line primitives are skipped", mesh_tag(mesh).c_str());
        }
        return;
    }
    auto attr = [&](const char *name) {
        auto it = pr.attributes.find(name);
        return it == pr.attributes.end() ? -1 : it->second;
    };
    int a_pos = attr("POSITION"), a_nrm = attr("NORMAL"), a_uv = attr("TEXCOORD_0");
    if (a_pos == -1) {
        skipped_no_position_++;
        if (!(warned & kWarnNoPosition)) {
            warned |= kWarnNoPosition;
            warn("%s primitive %d: no POSITION attribute; skipped", mesh_tag(mesh).c_str(), prim);
        }
        return;
    }
    if (!pr.targets.empty() && !(warned & kWarnMorph)) {
        warned |= kWarnMorph;
        warn("%s: morph targets are not supported; using the base shape", mesh_tag(mesh).c_str());
    }

    // --- read and validate everything before producing output
    Access pa = access(a_pos, "POSITION", TINYGLTF_TYPE_VEC3, {kF32});
    const uint64_t n = pa.count;
    if (n > kMaxVertices)
        fail(PN_ERR_MEMORY, "accessor %d (POSITION): %llu vertices exceed the limit of %llu",
             a_pos, (unsigned long long)n, (unsigned long long)kMaxVertices);
    decode_floats(pa, pos_);
    for (uint64_t i = 0; i < n * 3; i++)
        if (!std::isfinite(pos_[i]))
            fail(PN_ERR_FORMAT, "accessor %d (POSITION): vertex %llu is not finite", a_pos,
                 (unsigned long long)(i / 3));
    bool has_nrm = a_nrm != -1, has_uv = a_uv != -1;
    if (has_nrm) {
        Access na = access(a_nrm, "NORMAL", TINYGLTF_TYPE_VEC3, {kF32});
        if (na.count != n)
            fail(PN_ERR_FORMAT, "accessor %d (NORMAL): count %llu differs from POSITION's %llu",
                 a_nrm, (unsigned long long)na.count, (unsigned long long)n);
        decode_floats(na, nrm_);
    }
    if (has_uv) {
        Access ua = access(a_uv, "TEXCOORD_0", TINYGLTF_TYPE_VEC2, {kF32, kU8, kU16});
        if (ua.count != n)
            fail(PN_ERR_FORMAT,
                 "accessor %d (TEXCOORD_0): count %llu differs from POSITION's %llu", a_uv,
                 (unsigned long long)ua.count, (unsigned long long)n);
        decode_floats(ua, uv_);
    }
    bool indexed = pr.indices != -1;
    uint64_t ni = n;
    if (indexed) {
        Access ia = access(pr.indices, "indices", TINYGLTF_TYPE_SCALAR, {kU8, kU16, kU32});
        decode_indices(ia, idx_);
        ni = ia.count;
        for (uint64_t i = 0; i < ni; i++)
            if (idx_[i] >= n)
                fail(PN_ERR_FORMAT,
                     "%s primitive %d: accessor %d: indices out of range (index %u >= %llu "
                     "vertices)",
                     mesh_tag(mesh).c_str(), prim, pr.indices, idx_[i], (unsigned long long)n);
    }

    // --- triangle list in the primitive's own vertex numbering
    uint64_t ntri = 0;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        ntri = ni / 3;
        if (ni % 3 && !(warned & kWarnTrailing)) {
            warned |= kWarnTrailing;
            warn("%s primitive %d: %llu vertices is not a multiple of 3; ignoring the rest",
                 mesh_tag(mesh).c_str(), prim, (unsigned long long)ni);
        }
    } else if (ni >= 3) {
        ntri = ni - 2;
    }
    if (ntri == 0) {
        skipped_empty_++;
        return;
    }
    if (ntri * 3 > kMaxIndices)
        fail(PN_ERR_MEMORY, "%s primitive %d: %llu triangles exceed the limit",
             mesh_tag(mesh).c_str(), prim, (unsigned long long)ntri);
    auto src = [&](uint64_t i) -> uint32_t { return indexed ? idx_[i] : (uint32_t)i; };
    tri_.resize(ntri * 3);
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        for (uint64_t i = 0; i < ntri * 3; i++)
            tri_[i] = src(i);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        // glTF: triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), keeping every other one's winding
        for (uint64_t i = 0; i < ntri; i++) {
            tri_[3 * i] = src(i);
            tri_[3 * i + 1] = src(i + 1 + (i & 1));
            tri_[3 * i + 2] = src(i + 2 - (i & 1));
        }
    } else { // fan: (v_{i+1}, v_{i+2}, v_0)
        for (uint64_t i = 0; i < ntri; i++) {
            tri_[3 * i] = src(i + 1);
            tri_[3 * i + 1] = src(i + 2);
            tri_[3 * i + 2] = src(0);
        }
    }
    const uint64_t out_verts = has_nrm ? n : ntri * 3;
    if (b_.scene.vertex_count + out_verts > kMaxVertices || b_.scene.index_count + ntri * 3 > kMaxIndices)
        fail(PN_ERR_MEMORY, "scene too large: more than %llu vertices or %llu indices",
             (unsigned long long)kMaxVertices, (unsigned long long)kMaxIndices);
    pn_scene_build_prim p{};
    p.positions = pos_.data();
    p.normals = has_nrm ? nrm_.data() : nullptr;
    p.uvs = has_uv ? uv_.data() : nullptr;
    p.vertex_count = n;
    p.triangles = tri_.data();
    p.triangle_count = ntri;
    p.material = material_for(mesh, pr.material);
    p.capture_mesh = capture_;
    uint64_t bad_vertex = 0;
    const uint32_t first_vertex = b_.scene.vertex_count;
    pn_result r = pn_scene_build_add_prim(&b_, &p, &xf, &bad_vertex);
    if (r == PN_ERR_FORMAT)
        fail(PN_ERR_FORMAT, "%s primitive %d: vertex %llu is not finite after the node transform",
             mesh_tag(mesh).c_str(), prim, (unsigned long long)bad_vertex);
    built(r);
    if (cur_posed_)
        keep_local(p, first_vertex, xf.det < 0.0);
}

// A primitive under an animated node, kept in its node's frame for pn_scene_pose: its local
// positions, normals, uvs and triangles (wound as the scene has them).
void Loader::keep_local(const pn_scene_build_prim &p, uint32_t first_vertex, bool mirrored)
{
    KeptPrim k{};
    k.prim.node = (uint32_t)cur_node_;
    k.prim.object = b_.scene.object_count; // the object traverse() adds after this mesh's primitives
    k.prim.first_vertex = first_vertex;
    k.prim.vertex_count = (uint32_t)p.vertex_count;
    k.prim.triangle_count = (uint32_t)p.triangle_count;
    k.prim.mirrored = mirrored;
    k.pos.assign(p.positions, p.positions + p.vertex_count * 3);
    if (p.normals)
        k.nrm.assign(p.normals, p.normals + p.vertex_count * 3);
    if (p.uvs)
        k.uv.assign(p.uvs, p.uvs + p.vertex_count * 2);
    k.tri.assign(p.triangles, p.triangles + p.triangle_count * 3);
    prims_.push_back(std::move(k));
}

uint32_t Loader::material_for(int mesh, int material)
{
    if (material >= 0 && (size_t)material < m_.materials.size())
        return (uint32_t)material;
    uint8_t &warned = mesh_warned_[(size_t)mesh];
    if (material != -1 && !(warned & kWarnMaterial)) {
        warned |= kWarnMaterial;
        warn("%s: material %d does not exist (%zu materials); using the default",
             mesh_tag(mesh).c_str(), material, m_.materials.size());
    }
    default_material_used_ = true;
    return (uint32_t)m_.materials.size();
}

void Loader::build_materials()
{
    for (size_t i = 0; i < m_.materials.size(); i++) {
        const tinygltf::PbrMetallicRoughness &pbr = m_.materials[i].pbrMetallicRoughness;
        pn_material mat{{1.0f, 1.0f, 1.0f, 1.0f}, -1, 0.0f, m_.materials[i].doubleSided};
        bool ok = pbr.baseColorFactor.size() == 4;
        for (size_t c = 0; ok && c < 4; c++)
            ok = std::isfinite(pbr.baseColorFactor[c]);
        if (ok) {
            for (size_t c = 0; c < 4; c++)
                mat.base_color[c] = (float)pbr.baseColorFactor[c];
        } else {
            warn("material %zu: baseColorFactor is not 4 finite numbers; using (1,1,1,1)", i);
        }
        if (pbr.baseColorTexture.index != -1)
            mat.texture = texture_for((int)i, pbr.baseColorTexture);
        // alphaMode: MASK cuts the surface out below alphaCutoff; BLEND (partial coverage) casts
        // as MASK at 0.5, a shadow ray being either blocked or not; OPAQUE ignores alpha.
        const tinygltf::Material &gm = m_.materials[i];
        if (gm.alphaMode == "MASK" || gm.alphaMode == "BLEND") {
            double cut = gm.alphaMode == "BLEND" ? 0.5 : gm.alphaCutoff;
            if (!(std::isfinite(cut) && cut > 0 && cut <= 1)) {
                warn("material %zu: alphaCutoff %g is not in (0, 1]; using 0.5", i, cut);
                cut = 0.5;
            }
            if (pbr.baseColorTexture.index != -1 && mat.texture < 0)
                warn("material %zu: its alpha texture cannot be read; the mask is skipped (the surface is "
                     "opaque where its base colour alpha is above the cutoff)", i);
            mat.alpha_cutoff = (float)cut;
        } else if (gm.alphaMode != "OPAQUE" && !gm.alphaMode.empty()) {
            warn("material %zu: alphaMode \"%.16s\" is not OPAQUE, MASK or BLEND; opaque", i, gm.alphaMode.c_str());
        }
        built(pn_scene_build_add_material(&b_, &mat));
    }
}

// The pn_scene texture for a material's baseColorTexture, decoding its image on first use.
int32_t Loader::texture_for(int material, const tinygltf::TextureInfo &info)
{
    int ti = info.index;
    if (ti < 0 || (size_t)ti >= m_.textures.size()) {
        warn("material %d: texture %d does not exist (%zu textures); drawn untextured",
             material, ti, m_.textures.size());
        return -1;
    }
    if (info.texCoord != 0)
        warn("material %d: baseColorTexture uses TEXCOORD_%d; only TEXCOORD_0 is loaded, "
             "using it instead",
             material, info.texCoord);
    int ii = m_.textures[(size_t)ti].source;
    if (ii < 0 || (size_t)ii >= m_.images.size()) {
        warn("texture %d: no image source%s; drawn untextured", ti,
             ii == -1 ? " (an image format extension?)" : "");
        return -1;
    }
    int32_t &slot = image_texture_[(size_t)ii];
    if (slot != -2)
        return slot;
    slot = -1;
    const tinygltf::Image &img = m_.images[(size_t)ii];
    const uint64_t w = img.width > 0 ? (uint64_t)img.width : 0;
    const uint64_t h = img.height > 0 ? (uint64_t)img.height : 0;
    const uint64_t comp = img.component >= 1 && img.component <= 4 ? (uint64_t)img.component : 0;
    const uint64_t bytes = img.bits == 8 ? 1 : img.bits == 16 ? 2 : 0;
    if (img.image.empty() || !w || !h || !comp || !bytes || w * h > (1ull << 28) ||
        img.image.size() < w * h * comp * bytes) {
        warn("image %d%s%s%s: not decoded (missing, unsupported or invalid); drawn untextured",
             ii, img.uri.empty() ? "" : " ('", img.uri.substr(0, 64).c_str(),
             img.uri.empty() ? "" : "')");
        return -1;
    }
    int32_t index;
    if (pn_scene_build_add_texture(&b_, (uint32_t)w, (uint32_t)h, (int)comp, (int)bytes, img.image.data(),
                                   &index) != PN_OK)
        fail(PN_ERR_MEMORY, "image %d: out of memory for %llux%llu pixels", ii,
             (unsigned long long)w, (unsigned long long)h);
    slot = index;
    return slot;
}

// Moves the result into *out.
void Loader::emit(pn_scene *out)
{
    if (default_material_used_) {
        const pn_material white{{1.0f, 1.0f, 1.0f, 1.0f}, -1, 0.0f, false}; // glTF's default material: single-sided
        built(pn_scene_build_add_material(&b_, &white));
    }
    std::snprintf(b_.scene.name, sizeof b_.scene.name, "%s", path_);
    pn_scene_build_finish(&b_, out);
    out->anim = anim_; // NULL without animations
    anim_ = nullptr;
}

// --- reading files: the scene and the buffers and images it references. tinygltf's own reader
// fopen()s whatever a URI names, which blocks forever on a FIFO and reads devices without end;
// these callbacks read regular files only, below the 4 GiB that glTF can address.

// Reads a whole regular file. On failure sets *why (no path in it) and returns false.
bool read_regular_file(const char *path, std::vector<unsigned char> *out, std::string *why)
{
    // O_NONBLOCK: opening a FIFO must not wait for a writer (fstat rejects it right after).
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        *why = std::string("cannot open: ") + std::strerror(errno);
        return false;
    }
    struct stat st;
    bool ok = false;
    if (fstat(fd, &st) != 0) {
        *why = std::string("cannot read: ") + std::strerror(errno);
    } else if (!S_ISREG(st.st_mode)) {
        *why = "cannot read: not a regular file";
    } else if (st.st_size == 0) {
        *why = "empty file";
    } else if ((uint64_t)st.st_size >= (1ull << 32)) {
        *why = "file too large for glTF (4 GiB or more)";
    } else {
        out->resize((size_t)st.st_size);
        size_t got = 0;
        while (got < out->size()) {
            ssize_t n = read(fd, out->data() + got, out->size() - got);
            if (n < 0 && errno == EINTR)
                continue;
            if (n <= 0) {
                // n == 0: the file shrank while being read
                *why = std::string("cannot read: ") + (n < 0 ? std::strerror(errno) : "file changed size");
                break;
            }
            got += (size_t)n;
        }
        ok = got == out->size();
    }
    close(fd);
    if (!ok)
        out->clear();
    return ok;
}

bool fs_file_exists(const std::string &path, void *)
{
    struct stat st;
    return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// No ~ or $VAR expansion: a URI is a path relative to the file, nothing else.
std::string fs_expand(const std::string &path, void *) { return path; }

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *)
{
    std::string why;
    if (read_regular_file(path.c_str(), out, &why))
        return true;
    if (err)
        *err += why;
    return false;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    if (err)
        *err += "penumbra never writes glTF";
    return false;
}

inline uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

// The binary glTF header and JSON chunk header, checked before tinygltf so that a truncated or
// foreign file gets a message saying what is wrong (tinygltf says "Invalid glTF binary" for all
// of these, and never looks at the version). Returns the problem, or "" when there is none.
std::string glb_header_problem(const std::vector<unsigned char> &b)
{
    const uint64_t size = b.size();
    if (size < 12)
        return "truncated: " + std::to_string(size) + " bytes is shorter than the 12-byte binary glTF header";
    if (std::memcmp(b.data(), "glTF", 4) != 0)
        return "not a binary glTF file (it does not start with 'glTF')";
    const uint32_t version = le32(&b[4]), length = le32(&b[8]);
    if (version != 2)
        return "binary glTF version " + std::to_string(version) + " is not supported (2 required)";
    if (length > size)
        return "truncated: the header declares " + std::to_string(length) + " bytes but the file has " +
               std::to_string(size);
    if (length < 20)
        return "the header declares " + std::to_string(length) + " bytes, too few for a JSON chunk";
    const uint32_t json_len = le32(&b[12]), json_type = le32(&b[16]);
    if (json_type != 0x4E4F534Au) // "JSON"
        return "the first chunk is not JSON";
    if (json_len == 0 || 20ull + json_len > length)
        return "the JSON chunk (" + std::to_string(json_len) + " bytes) does not fit in the file's " +
               std::to_string(length) + " bytes (truncated?)";
    return std::string();
}

// tinygltf 2.7 (with its JSON library) recurses once per level of JSON nesting: a document
// nested some 10^4 levels deep, 20 KB of brackets, overflows the stack (SIGSEGV). glTF's own
// structure is a few levels deep and extras never need hundreds, so deeper nesting is refused
// before tinygltf sees it.
constexpr int kMaxJsonDepth = 512;

// True when arrays and objects in `json` nest deeper than kMaxJsonDepth (brackets in strings do
// not count).
bool json_too_deep(const char *json, size_t n)
{
    int depth = 0;
    bool in_string = false;
    for (size_t i = 0; i < n; i++) {
        const char c = json[i];
        if (in_string) {
            if (c == '\\')
                i++; // skip the escaped character
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth)
                return true;
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return false;
}

// When tinygltf rejects a file, a likelier cause than its message: a required extension this
// loader cannot decode (tinygltf then trips over the accessors the extension replaces) or a
// glTF 1.0 file (tinygltf wants asset.version to be a string). A plain text scan, since the JSON
// did not parse into a model: it only ever picks the message, never accepts a file.
std::string parse_failure_hint(const char *json, size_t n)
{
    const std::string text(json, n);
    size_t req = text.find("\"extensionsRequired\"");
    if (req != std::string::npos) {
        size_t open = text.find('[', req), close = text.find(']', req);
        if (open != std::string::npos && close != std::string::npos && open < close) {
            const std::string list = text.substr(open, close - open);
            static const char *const kUndecodable[][2] = {
                {"KHR_draco_mesh_compression", "Draco-compressed meshes"},
                {"EXT_meshopt_compression", "meshoptimizer-compressed buffers"},
                {"KHR_mesh_quantization", "quantized vertex attributes"},
            };
            for (const auto &e : kUndecodable)
                if (list.find(std::string("\"") + e[0] + "\"") != std::string::npos)
                    return std::string("requires extension ") + e[0] + " (" + e[1] + "), which is not supported";
        }
    }
    size_t asset = text.find("\"asset\"");
    size_t ver = asset == std::string::npos ? asset : text.find("\"version\"", asset);
    if (ver != std::string::npos && ver - asset < 512) {
        size_t v = text.find_first_not_of(" \t\r\n:", ver + 9);
        if (v != std::string::npos && (text.compare(v, 1, "1") == 0 || text.compare(v, 3, "\"1.") == 0))
            return "glTF version 1 is not supported (2.x required)";
    }
    return std::string();
}

pn_result load(const char *path, pn_scene *out)
{
    bool binary;
    if (ends_with_ci(path, ".glb")) {
        binary = true;
    } else if (ends_with_ci(path, ".gltf")) {
        binary = false;
    } else {
        pn_error("%s: not a glTF file (expected the extension .gltf or .glb)", path);
        return PN_ERR_FORMAT;
    }
    // The file is read here rather than by tinygltf, to tell an unreadable file (PN_ERR_IO) from a
    // malformed one (PN_ERR_FORMAT), which tinygltf reports the same way.
    std::vector<unsigned char> bytes;
    std::string why;
    if (!read_regular_file(path, &bytes, &why)) {
        pn_error("%s: %s", path, why.c_str());
        return why.compare(0, 6, "cannot") == 0 ? PN_ERR_IO : PN_ERR_FORMAT;
    }
    const char *json = reinterpret_cast<const char *>(bytes.data());
    size_t json_len = bytes.size();
    if (binary) {
        std::string problem = glb_header_problem(bytes);
        if (!problem.empty()) {
            pn_error("%s: %s", path, problem.c_str());
            return PN_ERR_FORMAT;
        }
        json += 20;
        json_len = le32(&bytes[12]);
    }
    if (json_too_deep(json, json_len)) {
        pn_error("%s: JSON nested deeper than %d levels", path, kMaxJsonDepth);
        return PN_ERR_FORMAT;
    }
    // URIs resolve against the file's folder, as tinygltf's own *FromFile functions do.
    const char *slash = std::strrchr(path, '/');
    const std::string base_dir = slash ? std::string(path, slash == path ? 1 : (size_t)(slash - path)) : "";

    tinygltf::Model model;
    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(load_image_lenient, &model);
    gltf.SetFsCallbacks(tinygltf::FsCallbacks{fs_file_exists, fs_expand, fs_read, fs_write, nullptr});
    std::string err, warn;
    bool ok = binary ? gltf.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                                 (unsigned int)bytes.size(), base_dir)
                     : gltf.LoadASCIIFromString(&model, &err, &warn, json, (unsigned int)json_len,
                                                base_dir);
    if (!warn.empty()) {
        size_t start = 0;
        while (start < warn.size()) {
            size_t end = warn.find('\n', start);
            if (end == std::string::npos)
                end = warn.size();
            std::string line = one_line(warn.substr(start, end - start));
            if (!line.empty())
                pn_warn("%s: %s", path, line.c_str());
            start = end + 1;
        }
    }
    if (!ok) {
        std::string msg = one_line(err);
        std::string hint = parse_failure_hint(json, json_len);
        if (!hint.empty())
            pn_error("%s: %s (tinygltf: %s)", path, hint.c_str(), msg.empty() ? "parse error" : msg.c_str());
        else
            pn_error("%s: %s", path, msg.empty() ? "tinygltf could not parse the file" : msg.c_str());
        // The file itself was readable (checked above); a buffer it names that cannot be read is
        // an I/O problem too (tinygltf's LoadExternalFile messages), anything else is the content.
        if (err.find("File not found") != std::string::npos ||
            err.find("File read error") != std::string::npos)
            return PN_ERR_IO;
        return PN_ERR_FORMAT;
    }
    Loader loader(path, model);
    loader.run();
    loader.emit(out);
    return PN_OK;
}

} // namespace

extern "C" pn_result pn_gltf_load(const char *path, pn_scene *out)
{
    assert(path && out);
    std::memset(out, 0, sizeof *out);
    pn_result r;
    try {
        r = load(path, out);
    } catch (const Failure &f) {
        r = f.result; // already logged
    } catch (const std::bad_alloc &) {
        pn_error("%s: out of memory", path);
        r = PN_ERR_MEMORY;
    } catch (const std::exception &e) {
        pn_error("%s: %s", path, one_line(e.what()).c_str());
        r = PN_ERR_FORMAT;
    } catch (...) {
        pn_error("%s: unexpected error while loading", path);
        r = PN_ERR_FORMAT;
    }
    if (r != PN_OK)
        std::memset(out, 0, sizeof *out);
    return r;
}
