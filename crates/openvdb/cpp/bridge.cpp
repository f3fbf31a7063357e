// isoview's bridge to the OpenVDB library: a C ABI over io::File, so the Rust side links
// against libopenvdb without a C++ binding generator. Every entry point catches every C++
// exception and hands back its message (one line; the Rust side locates it); nothing here
// throws across the boundary or aborts.
//
// Files are opened with delayed loading off (io::File::open(false)): OpenVDB then reads
// through a stream instead of mapping the file, so a file truncated while it is read is an
// exception, never SIGBUS.

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>

#include <cctype>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace {

// Error messages: at most this many bytes are handed back (an exception quoting file
// contents cannot make a message grow with the input).
constexpr size_t MAX_MESSAGE = 400;

void set_error(char* err, size_t cap, const std::string& what) {
    if (!err || cap == 0) return;
    // OpenVDB pads some messages with spaces (a KeyError's name field): trimmed.
    size_t end = what.size();
    while (end > 0 && std::isspace(static_cast<unsigned char>(what[end - 1]))) --end;
    size_t n = std::min(end, std::min(cap - 1, MAX_MESSAGE));
    std::memcpy(err, what.data(), n);
    err[n] = 0;
}

std::once_flag init_flag;

void init() {
    std::call_once(init_flag, [] {
        openvdb::initialize();
        // TBB loads its allocator (libtbbmalloc, whose constructor registers an exit handler)
        // at its first parallel allocation: do one here, in the parent, so that a forked
        // reader never loads it (a child forked while another thread held glibc's atexit lock
        // waited on it for ever: seen in the test suite, in countActiveVoxels' first node
        // manager). The same call the reader makes, on a grid of one voxel.
        try {
            openvdb::FloatGrid::Ptr one = openvdb::FloatGrid::create(0.0f);
            one->tree().setValueOn(openvdb::Coord(0, 0, 0), 1.0f);
            (void)one->tree().activeVoxelCount();
        } catch (...) {
            // Only a warm-up: the reader reports its own errors.
        }
    });
}

}  // namespace

// OpenVDB's one-time set-up, for the parent to run before it forks a reader: the set-up
// registers exit handlers (atexit), and a child forked while another thread of the parent held
// glibc's atexit lock waited on that lock for ever (seen in the test suite's threads).
extern "C" void ivdb_initialize() { init(); }

struct ivdb_file {
    std::unique_ptr<openvdb::io::File> file;
    openvdb::GridPtrVecPtr metas;
    std::vector<std::string> names;
    std::vector<std::string> types;
    std::vector<std::string> classes;
    uint64_t size = 0;
};

struct ivdb_grid {
    openvdb::GridBase::Ptr grid;
    openvdb::FloatGrid::Ptr f32;
    openvdb::DoubleGrid::Ptr f64;
};

// The transform and tree of one grid, as the Rust side reads them.
struct ivdb_grid_info {
    // 1: a linear map (scale, rotation, translation, affine); 0: not (frustum and others).
    int32_t linear;
    // The map's type name (openvdb::math::MapBase::type()), NUL-terminated.
    char map_type[64];
    // world = [i j k 1] * mat (row vectors, OpenVDB's convention), row-major.
    double mat[16];
    // Active-voxel index bounding box, inclusive; empty: min > max.
    int32_t bbox_min[3];
    int32_t bbox_max[3];
    double background;
    // 0 unknown, 1 level set, 2 fog volume, 3 staggered (GridClass).
    int32_t grid_class;
    // 32 or 64: the grid's value type is float or double.
    int32_t bits;
    // Half floats on disk (the grid's "is_saved_as_half_float" metadata).
    int32_t half;
    uint64_t active_voxels;
    uint64_t leaf_count;
};

extern "C" {

ivdb_file* ivdb_open(const char* path, char* err, size_t cap) {
    try {
        init();
        auto f = std::make_unique<ivdb_file>();
        {
            std::ifstream probe(path, std::ios::binary | std::ios::ate);
            if (!probe) {
                set_error(err, cap, "cannot be opened");
                return nullptr;
            }
            f->size = static_cast<uint64_t>(probe.tellg());
        }
        f->file = std::make_unique<openvdb::io::File>(path);
        f->file->setCopyMaxBytes(0);
        f->file->open(/*delayLoad=*/false);
        f->metas = f->file->readAllGridMetadata();
        for (const auto& g : *f->metas) {
            f->names.push_back(g->getName());
            f->types.push_back(g->valueType());
            f->classes.push_back(openvdb::GridBase::gridClassToString(g->getGridClass()));
        }
        return f.release();
    } catch (const std::exception& e) {
        set_error(err, cap, e.what());
    } catch (...) {
        set_error(err, cap, "unknown C++ exception");
    }
    return nullptr;
}

void ivdb_close(ivdb_file* f) {
    try {
        if (f && f->file && f->file->isOpen()) f->file->close();
    } catch (...) {
    }
    delete f;
}

size_t ivdb_grid_count(const ivdb_file* f) { return f->names.size(); }

const char* ivdb_grid_name(const ivdb_file* f, size_t i) { return f->names[i].c_str(); }

const char* ivdb_grid_type(const ivdb_file* f, size_t i) { return f->types[i].c_str(); }

const char* ivdb_grid_class(const ivdb_file* f, size_t i) { return f->classes[i].c_str(); }

// Reads grid `index` (a float or double grid) whole into memory and describes it.
ivdb_grid* ivdb_read(ivdb_file* f, size_t index, ivdb_grid_info* info, char* err, size_t cap) {
    try {
        const std::string& name = f->names.at(index);
        // readGrid(name) reads the first grid of that name; names in a file are unique
        // (OpenVDB writes duplicates as "name[1]"), and the index picked the grid by name.
        auto g = std::make_unique<ivdb_grid>();
        g->grid = f->file->readGrid(name);
        if (!g->grid) {
            set_error(err, cap, "grid not found");
            return nullptr;
        }
        g->f32 = openvdb::gridPtrCast<openvdb::FloatGrid>(g->grid);
        g->f64 = openvdb::gridPtrCast<openvdb::DoubleGrid>(g->grid);
        if (!g->f32 && !g->f64) {
            set_error(err, cap, "not a float or double grid");
            return nullptr;
        }
        std::memset(info, 0, sizeof(*info));
        const auto& xf = g->grid->transform();
        auto map = xf.baseMap();
        info->linear = xf.isLinear() ? 1 : 0;
        std::string mt = map->type();
        std::strncpy(info->map_type, mt.c_str(), sizeof(info->map_type) - 1);
        if (info->linear) {
            openvdb::math::Mat4d m = map->getAffineMap()->getMat4();
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c) info->mat[r * 4 + c] = m(r, c);
        }
        openvdb::CoordBBox box = g->grid->evalActiveVoxelBoundingBox();
        for (int k = 0; k < 3; ++k) {
            info->bbox_min[k] = box.min()[k];
            info->bbox_max[k] = box.max()[k];
        }
        info->grid_class = static_cast<int32_t>(g->grid->getGridClass());
        info->half = g->grid->saveFloatAsHalf() ? 1 : 0;
        info->active_voxels = g->grid->activeVoxelCount();
        if (g->f32) {
            info->bits = 32;
            info->background = g->f32->background();
            info->leaf_count = g->f32->tree().leafCount();
        } else {
            info->bits = 64;
            info->background = g->f64->background();
            info->leaf_count = g->f64->tree().leafCount();
        }
        return g.release();
    } catch (const std::exception& e) {
        set_error(err, cap, e.what());
    } catch (...) {
        set_error(err, cap, "unknown C++ exception");
    }
    return nullptr;
}

void ivdb_grid_free(ivdb_grid* g) { delete g; }

// How many nodes of each kind the grid's tree has: counts[0] root tiles (active or not),
// counts[1] upper internal nodes (32^3 entries), counts[2] lower internal nodes (16^3),
// counts[3] leaves (8^3 voxels). What `ivdb_tree_export` writes is sized from them.
int ivdb_tree_counts(const ivdb_grid* g, uint64_t* counts, char* err, size_t cap) {
    try {
        auto count = [&](const auto& grid) {
            const auto& root = grid->tree().root();
            counts[0] = counts[1] = counts[2] = counts[3] = 0;
            for (auto t = root.cbeginValueAll(); t; ++t) ++counts[0];
            for (auto u = root.cbeginChildOn(); u; ++u) {
                ++counts[1];
                for (auto l = u->cbeginChildOn(); l; ++l) {
                    ++counts[2];
                    counts[3] += l->getChildMask().countOn();
                }
            }
        };
        if (g->f32)
            count(g->f32);
        else
            count(g->f64);
        return 0;
    } catch (const std::exception& e) {
        set_error(err, cap, e.what());
    } catch (...) {
        set_error(err, cap, "unknown C++ exception");
    }
    return 1;
}

// The tree's nodes as records, little-endian, in this order (counts from ivdb_tree_counts):
//   root tiles:  origin (3 x int32), value (float)
//   upper nodes: origin (3 x int32), 32^3 floats: each entry's tile value (0 where a child is)
//   lower nodes: origin (3 x int32), 16^3 floats, the same
//   leaves:      origin (3 x int32), 8^3 floats, active or not
// Entries are in OpenVDB's offset order (x slowest, z fastest). Double grids are rounded to
// float. `out` holds `len` bytes: exactly what the counts make, else nothing is written.
int ivdb_tree_export(const ivdb_grid* g, const uint64_t* counts, uint8_t* out, size_t len,
                     char* err, size_t cap) {
    try {
        const uint64_t need = counts[0] * 16 + counts[1] * (12 + 4 * 32768) +
                              counts[2] * (12 + 4 * 4096) + counts[3] * (12 + 4 * 512);
        if (need != len) {
            set_error(err, cap, "the export's size does not match the tree's counts");
            return 1;
        }
        uint8_t* p = out;
        uint8_t* const end = out + len;
        auto put_coord = [&](const openvdb::Coord& c) {
            for (int k = 0; k < 3; ++k) {
                int32_t v = c[k];
                std::memcpy(p, &v, 4);
                p += 4;
            }
        };
        auto put_float = [&](float v) {
            std::memcpy(p, &v, 4);
            p += 4;
        };
        auto run = [&](const auto& grid) -> bool {
            const auto& root = grid->tree().root();
            uint64_t seen[4] = {0, 0, 0, 0};
            for (auto t = root.cbeginValueAll(); t; ++t) {
                if (++seen[0] > counts[0]) return false;
                put_coord(t.getCoord());
                put_float(static_cast<float>(*t));
            }
            // Internal nodes: every entry that is not a child holds a tile value (active or
            // inactive); entries holding children are written as 0 and never read.
            auto put_node = [&](const auto& node, size_t entries) {
                put_coord(node.origin());
                uint8_t* table = p;
                std::memset(table, 0, entries * 4);
                for (auto v = node.cbeginValueAll(); v; ++v) {
                    float f = static_cast<float>(*v);
                    std::memcpy(table + 4 * v.pos(), &f, 4);
                }
                p += entries * 4;
            };
            for (auto u = root.cbeginChildOn(); u; ++u) {
                if (++seen[1] > counts[1]) return false;
                put_node(*u, 32768);
            }
            for (auto u = root.cbeginChildOn(); u; ++u)
                for (auto l = u->cbeginChildOn(); l; ++l) {
                    if (++seen[2] > counts[2]) return false;
                    put_node(*l, 4096);
                }
            for (auto u = root.cbeginChildOn(); u; ++u)
                for (auto l = u->cbeginChildOn(); l; ++l)
                    for (auto leaf = l->cbeginChildOn(); leaf; ++leaf) {
                        if (++seen[3] > counts[3]) return false;
                        put_coord(leaf->origin());
                        for (openvdb::Index n = 0; n < 512; ++n)
                            put_float(static_cast<float>(leaf->getValue(n)));
                    }
            return p == end;
        };
        bool ok = g->f32 ? run(g->f32) : run(g->f64);
        if (!ok) {
            set_error(err, cap, "the tree changed while it was exported");
            return 1;
        }
        return 0;
    } catch (const std::exception& e) {
        set_error(err, cap, e.what());
    } catch (...) {
        set_error(err, cap, "unknown C++ exception");
    }
    return 1;
}

}  // extern "C"
