#include "renderer/input/loop_subdiv.h"

#include <algorithm>
#include <unordered_map>

namespace tessera {

namespace {

uint64_t edge_key(uint32_t a, uint32_t b) {
    if (a > b) std::swap(a, b);
    return (uint64_t(a) << 32) | b;
}

/// Per-edge record: its new (odd) vertex, and the vertices opposite to it in its faces.
struct Edge {
    uint32_t a, b;
    uint32_t opposite[2] = {0, 0};
    int faces = 0;
    uint32_t odd = 0;
};

/// One-ring data of the current mesh.
struct Topology {
    std::vector<Edge> edges;
    std::unordered_map<uint64_t, uint32_t> edge_index;
    std::vector<std::vector<uint32_t>> neighbours;  // per vertex
    std::vector<uint8_t> boundary;                   // per vertex
};

Topology build_topology(size_t nverts, const std::vector<uint32_t> &idx) {
    Topology t;
    t.edge_index.reserve(idx.size());
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
        for (int e = 0; e < 3; ++e) {
            uint32_t a = idx[f + size_t(e)], b = idx[f + size_t((e + 1) % 3)];
            uint32_t c = idx[f + size_t((e + 2) % 3)];
            auto [it, inserted] = t.edge_index.emplace(edge_key(a, b), uint32_t(t.edges.size()));
            if (inserted) t.edges.push_back(Edge{a, b});
            Edge &ed = t.edges[it->second];
            if (ed.faces < 2) ed.opposite[ed.faces] = c;
            ++ed.faces;
        }
    }
    t.neighbours.assign(nverts, {});
    t.boundary.assign(nverts, 0);
    for (const Edge &e : t.edges) {
        t.neighbours[e.a].push_back(e.b);
        t.neighbours[e.b].push_back(e.a);
        if (e.faces != 2) t.boundary[e.a] = t.boundary[e.b] = 1;
    }
    return t;
}

/// Loop's (Warren's) weight for an interior vertex of valence k.
double beta(size_t k) { return k == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * double(k)); }

/// The two boundary neighbours of boundary vertex v (along boundary edges).
std::pair<uint32_t, uint32_t> boundary_neighbours(const Topology &t, uint32_t v) {
    uint32_t nb[2] = {v, v};
    int found = 0;
    for (uint32_t w : t.neighbours[v]) {
        const Edge &e = t.edges[t.edge_index.at(edge_key(v, w))];
        if (e.faces != 2 && found < 2) nb[found++] = w;
    }
    if (found < 2) nb[1] = nb[0];
    return {nb[0], nb[1]};
}

}  // namespace

SubdividedMesh loop_subdivide(const std::vector<Vec3f> &p_in, const std::vector<uint32_t> &idx_in,
                              int levels) {
    std::vector<Vec3f> p = p_in;
    std::vector<uint32_t> idx = idx_in;
    for (int level = 0; level < levels; ++level) {
        Topology t = build_topology(p.size(), idx);
        std::vector<Vec3f> np(p.size() + t.edges.size());
        // Even vertices: smoothed old positions.
        for (uint32_t v = 0; v < p.size(); ++v) {
            const auto &ring = t.neighbours[v];
            if (ring.empty()) {
                np[v] = p[v];
            } else if (t.boundary[v]) {
                auto [b0, b1] = boundary_neighbours(t, v);
                np[v] = p[v] * 0.75f + (p[b0] + p[b1]) * 0.125f;
            } else {
                double b = beta(ring.size());
                Vec3f sum;
                for (uint32_t w : ring) sum += p[w];
                np[v] = p[v] * float(1.0 - double(ring.size()) * b) + sum * float(b);
            }
        }
        // Odd vertices: one per edge.
        for (size_t e = 0; e < t.edges.size(); ++e) {
            Edge &ed = t.edges[e];
            ed.odd = uint32_t(p.size() + e);
            if (ed.faces == 2)
                np[ed.odd] = (p[ed.a] + p[ed.b]) * 0.375f +
                             (p[ed.opposite[0]] + p[ed.opposite[1]]) * 0.125f;
            else
                np[ed.odd] = (p[ed.a] + p[ed.b]) * 0.5f;
        }
        // Each triangle becomes four, keeping its orientation.
        std::vector<uint32_t> nidx;
        nidx.reserve(idx.size() * 4);
        for (size_t f = 0; f + 2 < idx.size(); f += 3) {
            uint32_t v0 = idx[f], v1 = idx[f + 1], v2 = idx[f + 2];
            uint32_t e01 = t.edges[t.edge_index.at(edge_key(v0, v1))].odd;
            uint32_t e12 = t.edges[t.edge_index.at(edge_key(v1, v2))].odd;
            uint32_t e20 = t.edges[t.edge_index.at(edge_key(v2, v0))].odd;
            nidx.insert(nidx.end(), {v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20});
        }
        p = std::move(np);
        idx = std::move(nidx);
    }

    SubdividedMesh out;
    // Limit positions (pbrt-v4 LoopSubdivide: loopGamma / boundary 1/5-3/5-1/5).
    Topology t = build_topology(p.size(), idx);
    out.p.resize(p.size());
    for (uint32_t v = 0; v < p.size(); ++v) {
        const auto &ring = t.neighbours[v];
        if (ring.empty()) {
            out.p[v] = p[v];
        } else if (t.boundary[v]) {
            auto [b0, b1] = boundary_neighbours(t, v);
            out.p[v] = p[v] * 0.6f + (p[b0] + p[b1]) * 0.2f;
        } else {
            double k = double(ring.size());
            double gamma = 1.0 / (k + 3.0 / (8.0 * beta(ring.size())));
            Vec3f sum;
            for (uint32_t w : ring) sum += p[w];
            out.p[v] = p[v] * float(1.0 - k * gamma) + sum * float(gamma);
        }
    }
    // Smooth normals: area-weighted face normals, oriented like the triangles.
    out.n.assign(out.p.size(), Vec3f());
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
        Vec3f a = out.p[idx[f]], b = out.p[idx[f + 1]], c = out.p[idx[f + 2]];
        Vec3f fn = cross(b - a, c - a);
        for (int i = 0; i < 3; ++i) out.n[idx[f + size_t(i)]] += fn;
    }
    for (Vec3f &n : out.n) {
        float l = length(n);
        n = l > 0 ? n / l : Vec3f(0, 0, 1);
    }
    out.indices = std::move(idx);
    return out;
}

}  // namespace tessera
