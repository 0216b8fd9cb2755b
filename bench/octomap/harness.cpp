// The OctoMap side of `cargo xtask bench`: integrates the recording's returns (the world points
// and scanner origins the library's geometry computed, exported by `bench-host export`) into an
// OcTree at the given resolution, timed, two ways:
//   insertPointCloud: per line, OctoMap's usual integration (rays from the scanner to every
//                     point: free cells along the ray, occupied at the end; max range 10 m);
//   updateNode:       per point, updateNode(point, occupied) only: no ray casting (a
//                     "points only" lower bound for OctoMap's cost).
// Prints one line per mode: mode=… res=… points=… seconds=… returns_per_second=…
// Build: g++ -O2 -std=c++17 -o harness harness.cpp -loctomap -loctomath
#include <octomap/octomap.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

struct Line {
    octomap::point3d origin;
    octomap::Pointcloud cloud;
};

static bool load(const char* path, std::vector<Line>& lines, size_t& points) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::vector<char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    size_t at = 0;
    auto f32 = [&](float& v) { std::memcpy(&v, &b[at], 4); at += 4; };
    points = 0;
    while (at + 16 <= b.size()) {
        uint32_t n;
        std::memcpy(&n, &b[at], 4);
        at += 4;
        Line line;
        float x, y, z;
        f32(x); f32(y); f32(z);
        line.origin = octomap::point3d(x, y, z);
        if (at + 12 * size_t(n) > b.size()) return false;
        for (uint32_t i = 0; i < n; ++i) {
            f32(x); f32(y); f32(z);
            line.cloud.push_back(x, y, z);
        }
        points += n;
        lines.push_back(std::move(line));
    }
    return true;
}

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: harness POINTS.bin RES_M [RES_M ...]\n");
        return 2;
    }
    std::vector<Line> lines;
    size_t points = 0;
    if (!load(argv[1], lines, points)) {
        std::fprintf(stderr, "harness: cannot read %s\n", argv[1]);
        return 1;
    }
    for (int a = 2; a < argc; ++a) {
        double res = std::atof(argv[a]);
        {
            octomap::OcTree tree(res);
            auto t = std::chrono::steady_clock::now();
            for (const Line& l : lines) tree.insertPointCloud(l.cloud, l.origin, 10.0);
            double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
            std::printf("mode=insertPointCloud res=%g points=%zu seconds=%g returns_per_second=%g leaves=%zu\n",
                        res, points, s, points / s, tree.getNumLeafNodes());
        }
        {
            octomap::OcTree tree(res);
            auto t = std::chrono::steady_clock::now();
            for (const Line& l : lines)
                for (size_t i = 0; i < l.cloud.size(); ++i) tree.updateNode(l.cloud[i], true);
            double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
            std::printf("mode=updateNode res=%g points=%zu seconds=%g returns_per_second=%g leaves=%zu\n",
                        res, points, s, points / s, tree.getNumLeafNodes());
        }
    }
    return 0;
}
