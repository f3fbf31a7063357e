// Compiled and run by make.py: what pyopenvdb cannot write (OpenVDB 10 writes BLOSC by
// default). ZIP copies of dense.vdb and torus.vdb (OpenVDB leaves ZIP out for level sets and
// fog volumes, Archive::setGridCompression: the torus keeps the active-mask compression
// only), and the sphere of sphere.vdb as a double grid (pyopenvdb has no DoubleGrid).
// g++ -std=c++17 make_extra.cpp -lopenvdb -ltbb -lImath
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>

int main() {
    openvdb::initialize();
    {
        openvdb::io::File in("dense.vdb");
        in.open(false);
        auto grids = in.getGrids();
        in.close();
        openvdb::io::File zip("dense_zip.vdb");
        zip.setCompression(openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
        zip.write(*grids);
        zip.close();
    }
    {
        openvdb::io::File in("torus.vdb");
        in.open(false);
        auto grids = in.getGrids();
        in.close();
        openvdb::io::File zip("torus_zip.vdb");
        zip.setCompression(openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
        zip.write(*grids);
        zip.close();
    }
    {
        openvdb::io::File in("sphere.vdb");
        in.open(false);
        auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(in.readGrid("sphere"));
        in.close();
        auto d = openvdb::DoubleGrid::create(double(f->background()));
        d->setTransform(f->transform().copy());
        d->setGridClass(f->getGridClass());
        d->setName("sphere");
        // Every value the float tree holds (voxels of its leaves, active or not, and tiles),
        // with its state; background elsewhere.
        auto acc = d->getAccessor();
        for (auto it = f->tree().cbeginValueAll(); it; ++it) {
            openvdb::CoordBBox b;
            it.getBoundingBox(b);
            if (it.isVoxelValue()) {
                acc.setValue(it.getCoord(), double(*it));
                if (!it.isValueOn()) acc.setValueOff(it.getCoord());
            } else {
                d->tree().fill(b, double(*it), it.isValueOn());
            }
        }
        openvdb::io::File out("sphere_double.vdb");
        out.write({d});
        out.close();
    }
    return 0;
}
