// wrapper.cpp: a small C++17 RAII wrapper over weft's C API, used the way an engine's cloth
// component would use it: a world, its render mesh's bindings and per-frame frames as RAII
// objects, localization split over two threads every frame.
//
//   c++ -std=c++17 -I include c_examples/wrapper.cpp target/ship/libweft.a -o wrapper
//   ./wrapper cells.weft
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "weft.h"

namespace weft {

// A failed call, with where it failed.
class Error : public std::runtime_error {
public:
    Error(const char* call, WeftResult result, const WeftErrorDetail& detail)
        : std::runtime_error(describe(call, result, detail)), result_(result), detail_(detail) {}
    WeftResult result() const noexcept { return result_; }
    const WeftErrorDetail& detail() const noexcept { return detail_; }

private:
    static std::string describe(const char* call, WeftResult r, const WeftErrorDetail& d) {
        std::string s = std::string(call) + ": " + weft_result_string(r);
        auto add = [&](const char* name, std::uint32_t v) {
            if (v != WEFT_NONE) s += std::string(", ") + name + " " + std::to_string(v);
        };
        add("triangle", d.triangle);
        add("vertex", d.vertex);
        add("material", d.material);
        add("cell", d.cell);
        add("needed", d.needed);
        add("capacity", d.capacity);
        if (d.what[0] != '\0') s += std::string(" (") + d.what + ")";
        return s;
    }
    WeftResult result_;
    WeftErrorDetail detail_;
};

namespace detail {
inline WeftErrorDetail none() {
    WeftErrorDetail d{};
    d.result = WEFT_RESULT_OK;
    d.triangle = d.vertex = d.vertex_b = d.material = d.cell = d.index = d.needed = d.capacity =
        WEFT_NONE;
    d.what = "";
    return d;
}
// Runs `call` with a detail to fill (the API's one error channel) and throws it on failure.
template <class Call>
inline void check(const char* name, Call call) {
    WeftErrorDetail d = none();
    WeftResult r = call(&d);
    if (r != WEFT_RESULT_OK) throw Error(name, r, d);
}
}  // namespace detail

// Owns a blob file's bytes (8-aligned) and its parsed view. Movable: the bytes stay put.
class Blob {
public:
    static Blob load(const std::string& path) {
        std::ifstream f(path, std::ios::binary);
        if (!f) throw std::runtime_error("cannot open " + path);
        std::vector<char> raw((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
        Blob b;
        b.size_ = raw.size();
        b.words_.resize((raw.size() + 7) / 8);  // uint64_t storage: WEFT_BLOB_ALIGN-aligned
        std::memcpy(b.words_.data(), raw.data(), raw.size());
        WeftErrorDetail d;
        WeftResult r = weft_blob_parse(b.words_.data(), b.size_, &b.blob_, &d);
        if (r != WEFT_RESULT_OK) throw Error("weft_blob_parse", r, d);
        return b;
    }
    const WeftBlob* get() const noexcept { return &blob_; }
    std::uint32_t cell_count() const noexcept { return blob_.cell_count; }
    WeftCellInfo cell(std::uint32_t i) const {
        WeftCellInfo info;
        detail::check("weft_blob_cell_info", [&](WeftErrorDetail* d) { return weft_blob_cell_info(&blob_, i, &info, d); });
        return info;
    }

private:
    Blob() = default;
    std::vector<std::uint64_t> words_;
    std::size_t size_ = 0;
    WeftBlob blob_{};
};

// Aligned heap bytes for weft's caller-owned blocks.
struct AlignedDelete {
    std::size_t align;
    void operator()(std::byte* p) const noexcept { ::operator delete(p, std::align_val_t{align}); }
};
using AlignedBytes = std::unique_ptr<std::byte, AlignedDelete>;
inline AlignedBytes aligned_bytes(std::size_t size, std::size_t align) {
    return AlignedBytes(static_cast<std::byte*>(::operator new(size, std::align_val_t{align})),
                        AlignedDelete{align});
}

// A render mesh's bindings to a cloth: plain bytes, movable, storable with the mesh asset.
class Bindings {
public:
    Bindings() = default;
    const void* data() const noexcept { return words_.data(); }
    std::size_t size() const noexcept { return size_; }
    std::uint32_t count() const noexcept { return count_; }

private:
    friend class World;
    std::vector<std::uint32_t> words_;  // WEFT_BIND_MEMORY_ALIGN-aligned
    std::size_t size_ = 0;
    std::uint32_t count_ = 0;
};

// A world's per-frame frames (filled by World::prepare). Movable; the bytes stay put.
class Frames {
public:
    Frames() = default;
    const void* data() const noexcept { return bytes_.get(); }

private:
    friend class World;
    AlignedBytes bytes_{nullptr, AlignedDelete{WEFT_LOCALIZE_FRAMES_ALIGN}};
    std::size_t size_ = 0;
};

// Owns a world and the aligned memory block it lives in. Move-only; destroyed before its memory
// is released. The blob must outlive it.
class World {
public:
    World(const WeftWorldDef& def, const Blob& blob) {
        std::size_t size = 0;
        detail::check("weft_world_memory_size", [&](WeftErrorDetail* d) { return weft_world_memory_size(&def.capacity, &size, d); });
        memory_ = aligned_bytes(size, weft_world_memory_align());
        WeftErrorDetail d;
        WeftResult r = weft_world_create(&def, blob.get(), memory_.get(), size, &world_, &d);
        if (r != WEFT_RESULT_OK) throw Error("weft_world_create", r, d);
    }
    ~World() {
        if (world_ != nullptr) weft_world_destroy(world_, NULL);
    }
    World(World&& o) noexcept
        : memory_(std::move(o.memory_)), world_(std::exchange(o.world_, nullptr)) {}
    World& operator=(World&& o) noexcept {
        if (this != &o) {
            if (world_ != nullptr) weft_world_destroy(world_, NULL);
            world_ = std::exchange(o.world_, nullptr);
            memory_ = std::move(o.memory_);
        }
        return *this;
    }
    World(const World&) = delete;
    World& operator=(const World&) = delete;

    WeftStepStats step(float dt) {
        WeftStepStats s;
        call("weft_world_step", [&](WeftErrorDetail* d) { return weft_world_step(world_, dt, &s, d); });
        return s;
    }
    void pin(std::uint32_t vertex, WeftVec3 target) {
        call("weft_world_set_pin", [&](WeftErrorDetail* d) { return weft_world_set_pin(world_, vertex, target, d); });
    }
    std::uint32_t add_collider(const WeftShape& shape, float friction) {
        WeftColliderDef def = weft_default_collider_def();
        def.shape = shape;
        def.friction = friction;
        std::uint32_t index = 0;
        call("weft_world_add_collider", [&](WeftErrorDetail* d) { return weft_world_add_collider(world_, &def, &index, d); });
        return index;
    }
    void move_collider(std::uint32_t index, const WeftShape& shape) {
        call("weft_world_set_collider", [&](WeftErrorDetail* d) { return weft_world_set_collider(world_, index, &shape, d); });
    }
    void set_effects(std::uint32_t effects) {
        call("weft_world_set_effects", [&](WeftErrorDetail* d) { return weft_world_set_effects(world_, effects, d); });
    }
    WeftSettings settings() const {
        WeftSettings s;
        detail::check("weft_world_get_settings", [&](WeftErrorDetail* d) { return weft_world_get_settings(world_, &s, d); });
        return s;
    }
    // Copies positions into any array of structs: `member` points at the position inside the
    // first element.
    template <class Vertex>
    void read_positions(std::vector<Vertex>& out, WeftVec3 Vertex::*member) const {
        detail::check("weft_world_get_positions", [&](WeftErrorDetail* d) { return weft_world_get_positions(world_, &(out.data()->*member),
                                               static_cast<std::uint32_t>(out.size()),
                                               sizeof(Vertex), d); });
    }
    void read_velocities(std::vector<WeftVec3>& out) const {
        out.resize(vertex_count());
        detail::check("weft_world_get_velocities", [&](WeftErrorDetail* d) { return weft_world_get_velocities(world_, out.data(),
                                                static_cast<std::uint32_t>(out.size()),
                                                sizeof(WeftVec3), d); });
    }
    std::uint32_t vertex_count() const noexcept { return weft_world_vertex_count(world_); }
    bool asleep() const noexcept { return weft_world_is_asleep(world_); }

    // Binds a render mesh (any array of structs holding a (u, v) `member`) to this cloth.
    template <class Vertex>
    Bindings bind(const std::vector<Vertex>& mesh, WeftVec2 Vertex::*member) const {
        Bindings b;
        b.count_ = static_cast<std::uint32_t>(mesh.size());
        detail::check("weft_bind_memory_size", [&](WeftErrorDetail* d) { return weft_bind_memory_size(b.count_, &b.size_, d); });
        b.words_.resize((b.size_ + 3) / 4);
        WeftErrorDetail d;
        WeftResult r = weft_bind(world_, &(mesh.data()->*member), b.count_, sizeof(Vertex),
                                 b.words_.data(), b.size_, &d);
        if (r != WEFT_RESULT_OK) throw Error("weft_bind", r, d);
        return b;
    }
    // Measures the cloth as it is now into `frames` (allocated on first use).
    void prepare(Frames& frames, std::uint32_t measure = WEFT_STRAIN_COROTATED) const {
        std::size_t size = 0;
        detail::check("weft_localize_frames_size", [&](WeftErrorDetail* d) { return weft_localize_frames_size(world_, &size, d); });
        if (frames.size_ != size) {
            frames.bytes_ = aligned_bytes(size, WEFT_LOCALIZE_FRAMES_ALIGN);
            frames.size_ = size;
        }
        WeftErrorDetail d;
        WeftResult r = weft_localize_prepare(world_, measure, frames.bytes_.get(), size, &d);
        if (r != WEFT_RESULT_OK) throw Error("weft_localize_prepare", r, d);
    }
    // Localizes render vertices [first, first + count) into `mesh`: positions and normals go
    // to the given members. Const: ranges may run on several threads at once.
    template <class Vertex>
    void localize(const Frames& frames, const Bindings& bindings, std::vector<Vertex>& mesh,
                  WeftVec3 Vertex::*position, WeftVec3 Vertex::*normal, std::uint32_t first,
                  std::uint32_t count, std::uint32_t normal_mode = WEFT_NORMALS_BLENDED,
                  const std::vector<std::uint32_t>* fine_indices = nullptr) const {
        if (static_cast<std::size_t>(first) + count > mesh.size())
            throw std::out_of_range("weft::World::localize: range beyond the mesh");
        WeftLocalizeOutput out = weft_default_localize_output();
        out.positions = &(mesh.data()[first].*position);
        out.position_stride = sizeof(Vertex);
        out.normals = &(mesh.data()[first].*normal);
        out.normal_stride = sizeof(Vertex);
        out.normal_mode = normal_mode;
        if (fine_indices != nullptr) {
            out.fine_indices = fine_indices->data();
            out.fine_triangle_count = static_cast<std::uint32_t>(fine_indices->size() / 3);
        }
        WeftErrorDetail d;
        WeftResult r = weft_localize(world_, frames.data(), bindings.data(), bindings.size(), first,
                                     count, &out, &d);
        if (r != WEFT_RESULT_OK) throw Error("weft_localize", r, d);
    }

private:
    // A call on the world, with its detail.
    template <class Call>
    void call(const char* name, Call c) {
        detail::check(name, c);
    }
    AlignedBytes memory_{nullptr, AlignedDelete{WEFT_WORLD_MEMORY_ALIGN}};
    WeftWorld* world_ = nullptr;
};

}  // namespace weft

// ---------------------------------------------------------------------------------------------
// An engine-side cloth component: owns its render vertices and its simulation.

struct RenderVertex {
    WeftVec3 position;
    WeftVec3 normal;
    WeftVec2 uv;
};

class ClothComponent {
public:
    // Render vertices per simulated edge: the render mesh is this many times finer.
    static constexpr int kFiner = 4;

    // A `cols` x `rows` flag of `width` metres held along its edge at `pole`, starting out
    // horizontal (along +y) and free to fall.
    ClothComponent(const weft::Blob& cells, std::uint32_t cell, int cols, int rows, float width,
                   WeftVec3 pole)
        : cols_(cols), rows_(rows) {
        float h = width / static_cast<float>(cols - 1);
        for (int j = 0; j < rows; ++j)
            for (int i = 0; i < cols; ++i) {
                RenderVertex v{};
                v.position = {pole.x + h * static_cast<float>(i),
                              pole.y + h * static_cast<float>(rows - 1 - j), pole.z};
                v.normal = {0.0f, 0.0f, 1.0f};
                v.uv = {h * static_cast<float>(i), h * static_cast<float>(j)};
                vertices_.push_back(v);
            }
        for (int j = 0; j + 1 < rows; ++j)
            for (int i = 0; i + 1 < cols; ++i) {
                std::uint32_t ll = static_cast<std::uint32_t>(j * cols + i), lr = ll + 1,
                              ul = ll + static_cast<std::uint32_t>(cols), ur = ul + 1;
                indices_.insert(indices_.end(), {ll, lr, ur, ll, ur, ul});
            }
        WeftWorldDef def = weft_default_world_def();
        def.positions = &vertices_.data()->position;
        def.position_stride = sizeof(RenderVertex);
        def.uvs = &vertices_.data()->uv;
        def.uv_stride = sizeof(RenderVertex);
        def.vertex_count = static_cast<std::uint32_t>(vertices_.size());
        def.indices = indices_.data();
        def.triangle_count = static_cast<std::uint32_t>(indices_.size() / 3);
        def.material = cell;
        def.capacity.max_vertices = def.vertex_count;
        def.capacity.max_triangles = def.triangle_count;
        def.capacity.max_edges = 3 * def.triangle_count;
        def.capacity.max_pins = static_cast<std::uint32_t>(cols);
        def.settings.substeps = 2;
        world_ = std::make_unique<weft::World>(def, cells);
        // The edge row j = rows - 1 is held by the pole.
        for (int i = 0; i < cols; ++i) {
            std::uint32_t v = static_cast<std::uint32_t>((rows - 1) * cols + i);
            world_->pin(v, vertices_[v].position);
        }
        // The render mesh: kFiner times finer over the same (u, v), bound once.
        int fc = kFiner * (cols - 1) + 1, fr = kFiner * (rows - 1) + 1;
        float fh = h / static_cast<float>(kFiner);
        for (int j = 0; j < fr; ++j)
            for (int i = 0; i < fc; ++i) {
                RenderVertex v{};
                v.uv = {fh * static_cast<float>(i), fh * static_cast<float>(j)};
                render_.push_back(v);
            }
        for (int j = 0; j + 1 < fr; ++j)
            for (int i = 0; i + 1 < fc; ++i) {
                std::uint32_t ll = static_cast<std::uint32_t>(j * fc + i), lr = ll + 1,
                              ul = ll + static_cast<std::uint32_t>(fc), ur = ul + 1;
                render_indices_.insert(render_indices_.end(), {ll, lr, ur, ll, ur, ul});
            }
        bindings_ = world_->bind(render_, &RenderVertex::uv);
        localize();
    }

    // Called once per frame by the engine.
    void update(float dt) {
        last_ = world_->step(dt);
        world_->read_positions(vertices_, &RenderVertex::position);
        // A sanity check an engine may afford: a vertex faster than 20 m/s means trouble.
        world_->read_velocities(velocities_);
        for (const WeftVec3& v : velocities_) {
            float s2 = v.x * v.x + v.y * v.y + v.z * v.z;
            if (s2 > top_speed2_) top_speed2_ = s2;
        }
        if (!(top_speed2_ < 400.0f)) throw std::runtime_error("the cloth exploded");
        localize();
    }
    // The render mesh follows the cloth: measured once, localized in two halves on two threads
    // (the calls only read the world, the frames and the bindings).
    void localize() {
        world_->prepare(frames_);
        std::uint32_t n = static_cast<std::uint32_t>(render_.size()), half = n / 2;
        std::exception_ptr failed;
        std::thread job([&] {
            try {
                world_->localize(frames_, bindings_, render_, &RenderVertex::position,
                                 &RenderVertex::normal, 0, half);
            } catch (...) {
                failed = std::current_exception();
            }
        });
        try {
            world_->localize(frames_, bindings_, render_, &RenderVertex::position,
                             &RenderVertex::normal, half, n - half);
        } catch (...) {
            job.join();
            throw;
        }
        job.join();
        if (failed) std::rethrow_exception(failed);
    }
    // The render mesh again, whole, with normals recomputed from its own triangles.
    void localize_exact_normals() {
        world_->prepare(frames_);
        world_->localize(frames_, bindings_, render_, &RenderVertex::position,
                         &RenderVertex::normal, 0, static_cast<std::uint32_t>(render_.size()),
                         WEFT_NORMALS_RECOMPUTED, &render_indices_);
    }
    // Tries this cloth's render mesh with bindings made for another cloth.
    void localize_with(const weft::Bindings& foreign) {
        world_->prepare(frames_);
        world_->localize(frames_, foreign, render_, &RenderVertex::position,
                         &RenderVertex::normal, 0, static_cast<std::uint32_t>(render_.size()));
    }
    const weft::Bindings& bindings() const { return bindings_; }
    const std::vector<RenderVertex>& render_vertices() const { return render_; }
    float top_speed2() const { return top_speed2_; }
    weft::World& world() { return *world_; }
    const std::vector<RenderVertex>& vertices() const { return vertices_; }
    const WeftStepStats& last_step() const { return last_; }
    int cols() const { return cols_; }

private:
    int cols_, rows_;
    std::vector<RenderVertex> vertices_;
    std::vector<std::uint32_t> indices_;
    std::vector<WeftVec3> velocities_ = std::vector<WeftVec3>(vertices_.size());
    std::vector<RenderVertex> render_;
    std::vector<std::uint32_t> render_indices_;
    std::unique_ptr<weft::World> world_;
    weft::Bindings bindings_;
    weft::Frames frames_;
    WeftStepStats last_{};
    float top_speed2_ = 0.0f;
};

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s CELLS.weft\n", argv[0]);
        return 2;
    }
    try {
        weft::Blob cells = weft::Blob::load(argv[1]);
        WeftCellInfo info = cells.cell(0);
        std::printf("blob: %u cell(s), cell 0 is '%s'\n", cells.cell_count(), info.name);

        // A flag held along its edge at 2 m falls onto a ball rolling past below.
        ClothComponent flag(cells, 0, 10, 8, 0.45f, WeftVec3{0.0f, 0.0f, 2.0f});
        auto ball_at = [](float t) { return weft_shape_sphere({0.1f + 0.2f * t, 0.2f, 1.7f}, 0.1f); };
        std::uint32_t ball = flag.world().add_collider(ball_at(0.0f), 0.4f);
        int most_contacts = 0;
        for (int frame = 1; frame <= 120; ++frame) {
            float t = static_cast<float>(frame) / 60.0f;
            flag.world().move_collider(ball, ball_at(t));
            if (frame == 90)  // the ball is gone: stop paying for collision
                flag.world().set_effects(flag.world().settings().effects & ~WEFT_EFFECT_COLLISION);
            flag.update(1.0f / 60.0f);
            if (static_cast<int>(flag.last_step().contacts) > most_contacts)
                most_contacts = static_cast<int>(flag.last_step().contacts);
        }
        const RenderVertex& corner = flag.vertices().front();
        const RenderVertex& held = flag.vertices().back();
        std::printf("after 120 frames: free corner at (%.3f, %.3f, %.3f), held corner z %.3f, "
                    "%d contacts at most, top speed %.2f m/s\n",
                    static_cast<double>(corner.position.x), static_cast<double>(corner.position.y),
                    static_cast<double>(corner.position.z), static_cast<double>(held.position.z),
                    most_contacts, static_cast<double>(std::sqrt(flag.top_speed2())));
        if (std::fabs(held.position.z - 2.0f) > 1e-5f || !(corner.position.z < 1.8f) ||
            most_contacts == 0) {
            std::printf("the flag did not fall onto the ball\n");
            return 1;
        }

        // The render mesh covers the flag: its corners sit on the simulated corners (same
        // (u, v)), up to the pattern's micro displacement.
        const std::vector<RenderVertex>& render = flag.render_vertices();
        auto gap_mm = [](const WeftVec3& a, const WeftVec3& b) {
            return 1000.0 * std::sqrt(static_cast<double>((a.x - b.x) * (a.x - b.x) +
                                                          (a.y - b.y) * (a.y - b.y) +
                                                          (a.z - b.z) * (a.z - b.z)));
        };
        double corner_gap = std::max(gap_mm(render.front().position, corner.position),
                                     gap_mm(render.back().position, held.position));
        std::vector<RenderVertex> blended = render;
        flag.localize_exact_normals();
        double min_dot = 1.0;
        for (std::size_t i = 0; i < render.size(); ++i) {
            const WeftVec3 &a = blended[i].normal, &b = render[i].normal;
            min_dot = std::min(min_dot, static_cast<double>(a.x * b.x + a.y * b.y + a.z * b.z));
        }
        std::printf("render mesh: %zu vertices (%d x finer), localized on 2 threads every frame; "
                    "corners %.4f mm from the simulated ones; recomputed normals within %.1f "
                    "degrees of the blended ones\n",
                    render.size(), ClothComponent::kFiner, corner_gap,
                    std::acos(std::min(1.0, min_dot)) * 180.0 / 3.14159265358979);
        if (!(corner_gap < 1.0) || !(min_dot > 0.5)) {
            std::printf("the render mesh does not follow the flag\n");
            return 1;
        }

        // Errors arrive as exceptions carrying the detail.
        try {
            flag.world().pin(100000, WeftVec3{0.0f, 0.0f, 0.0f});
            std::printf("an out-of-range pin was accepted\n");
            return 1;
        } catch (const weft::Error& e) {
            std::printf("caught: %s\n", e.what());
            if (e.result() != WEFT_RESULT_VERTEX_OUT_OF_RANGE || e.detail().vertex != 100000)
                return 1;
        }
        try {
            ClothComponent missing(cells, 7, 10, 8, 0.45f, WeftVec3{0.0f, 0.0f, 2.0f});
            std::printf("a missing cell was accepted\n");
            return 1;
        } catch (const weft::Error& e) {
            std::printf("caught: %s\n", e.what());
            if (e.result() != WEFT_RESULT_MATERIAL_OUT_OF_RANGE) return 1;
        }
        try {
            // Bindings belong to one cloth: another flag refuses them.
            ClothComponent small(cells, 0, 6, 5, 0.3f, WeftVec3{1.0f, 0.0f, 2.0f});
            small.localize_with(flag.bindings());
            std::printf("foreign bindings were accepted\n");
            return 1;
        } catch (const weft::Error& e) {
            std::printf("caught: %s\n", e.what());
            if (e.result() != WEFT_RESULT_BINDINGS_MISMATCH) return 1;
        }
        // Worlds move without copying: the handle and its block travel together.
        weft::World moved = std::move(flag.world());
        std::printf("moved world: %u vertices\n", moved.vertex_count());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    std::printf("wrapper: ok\n");
    return 0;
}
