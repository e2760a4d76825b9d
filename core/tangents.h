// Per-vertex tangent frames for tangent-space normal maps, generated where a
// glTF primitive has no TANGENT attribute. The glTF 2.0 specification (3.7.2.1,
// "Meshes: Overview") asks for MikkTSpace tangents then; this is our own
// implementation of the algorithm as Mikkelsen describes it ("Simulation of
// wrinkled surfaces revisited", 2008, and the MikkTSpace documentation):
//
//   1. per triangle, the tangent and bitangent from the UV derivatives,
//      dP/du and dP/dv (solving the 2x2 system of two edges);
//   2. at each corner, both projected onto the plane of that vertex's normal
//      (Gram-Schmidt), normalised, and weighted by the corner's angle;
//   3. summed over every corner that shares position, normal and UV (a
//      vertex repeated in the index buffer, or duplicated with equal
//      attributes, gets one frame), then normalised and orthogonalised
//      against the normal once more;
//   4. the handedness w = +1 when cross(n, t) points along the summed
//      bitangent, else -1 (glTF: bitangent = cross(normal, tangent.xyz) * w).
//
// Known difference from the reference implementation: it splits a vertex
// whose triangles disagree in UV orientation (a mirrored seam through one
// welded vertex) into two; here such a vertex gets one frame (the loader
// does not split vertices).
#pragma once

#include <cstdint>
#include <span>

#include "core/math.h"

namespace vsl {

// Fills tangents[v] (unit, or zero where undefined) and signs[v] (+1 or -1)
// for every vertex v in [first, positions.size()) from the triangles tris
// (absolute vertex indices, 3 per triangle). A zero normal means "use the
// triangle's geometric normal" there (flat shading, as the loader stores it).
// Triangles with a degenerate UV mapping contribute nothing.
void generateMikkTangents(std::span<const Vec3> positions, std::span<const Vec3> normals, std::span<const Vec2> uvs,
                          std::span<const uint32_t> tris, uint32_t first, std::span<Vec3> tangents,
                          std::span<float> signs);

}  // namespace vsl
