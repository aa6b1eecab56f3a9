/* vdb_writer.cpp - see vdb_writer.h.  Test-only: exceptions become -1 and a message. */
#include "vdb_writer.h"

#include <cstdio>
#include <exception>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>

namespace {

openvdb::math::Transform::Ptr make_transform(const vdbw_grid &g)
{
    if (g.frustum) {
        const openvdb::BBoxd box(openvdb::Vec3d(0, 0, 0), openvdb::Vec3d(16, 16, 16));
        return openvdb::math::Transform::createFrustumTransform(box, /*taper=*/0.5, /*depth=*/10.0, /*voxelDim=*/1.0);
    }
    bool zero = true;
    for (double m : g.matrix) zero = zero && m == 0.0;
    /* OpenVDB multiplies row vectors: world = index * M, so M holds the transpose of the
       column-vector matrix and the translation in its last row. */
    openvdb::Mat4d m = openvdb::Mat4d::identity();
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) m[c][r] = zero ? (r == c ? 1.0 : 0.0) : g.matrix[3 * r + c];
        m[3][r] = g.translation[r];
    }
    return openvdb::math::Transform::createLinearTransform(m);
}

template <typename GridT, typename Make>
openvdb::GridBase::Ptr make_grid(const vdbw_grid &g, Make value)
{
    typename GridT::Ptr grid = GridT::create(value(g.background));
    typename GridT::Accessor acc = grid->getAccessor();
    for (size_t i = 0; i < g.inactive_count; i++) {
        const int32_t *c = g.inactive[i].ijk;
        acc.setValueOff(openvdb::Coord(c[0], c[1], c[2]), value(g.inactive[i].value));
    }
    for (size_t i = 0; i < g.active_count; i++) {
        const int32_t *c = g.active[i].ijk;
        acc.setValueOn(openvdb::Coord(c[0], c[1], c[2]), value(g.active[i].value));
    }
    if (g.has_tile)
        grid->tree().addTile(1, openvdb::Coord(g.tile_ijk[0], g.tile_ijk[1], g.tile_ijk[2]), value(g.tile_value), true);
    return grid;
}

} // namespace

extern "C" int vdbw_write(const char *path, const vdbw_grid *grids, size_t count, int compression,
                          char *err, size_t err_size)
{
    try {
        openvdb::initialize();
        openvdb::GridPtrVec out;
        for (size_t k = 0; k < count; k++) {
            const vdbw_grid &g = grids[k];
            openvdb::GridBase::Ptr grid;
            if (g.share_tree_of > 0 && (size_t)g.share_tree_of <= k) {
                grid = out[(size_t)g.share_tree_of - 1]->copyGrid();   /* shares the tree */
            } else if (g.type == VDBW_FLOAT) {
                grid = make_grid<openvdb::FloatGrid>(g, [](double v) { return (float)v; });
            } else if (g.type == VDBW_DOUBLE) {
                grid = make_grid<openvdb::DoubleGrid>(g, [](double v) { return v; });
            } else {
                grid = make_grid<openvdb::Vec3SGrid>(g, [](double v) { return openvdb::Vec3s((float)v); });
            }
            grid->setName(g.name ? g.name : "");
            grid->setTransform(make_transform(g));
            grid->setSaveFloatAsHalf(g.half != 0);
            grid->setGridClass(openvdb::GRID_FOG_VOLUME);
            out.push_back(grid);
        }
        openvdb::io::File file(path);
        if (compression >= 0) file.setCompression((uint32_t)compression);
        file.write(out);
        file.close();
        return 0;
    } catch (const std::exception &e) {
        if (err && err_size) std::snprintf(err, err_size, "%s: %s", path, e.what());
    } catch (...) {
        if (err && err_size) std::snprintf(err, err_size, "%s: unknown failure", path);
    }
    return -1;
}
