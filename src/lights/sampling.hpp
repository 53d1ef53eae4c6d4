// Internal: deterministic, stratified point sets on the unit disk and on the sphere, and the
// solid angles of the shapes they cover. The light model draws its samples from them
// (lightSamples, lightSampleDirections in lights.hpp), the bitmask technique its disk samples
// (shadows/bitmask.hpp), the ambient residual its polygon quadrature. Each set is uniform in area
// (disk) or in solid angle (cap, triangle, polygon); tests/test_sampling.cpp checks them against
// closed forms.
#pragma once
#include <array>
#include <vector>

#include "core/vec3.hpp"

namespace penumbra::detail {

// Point k of n on the unit disk: a Fibonacci spiral, radius sqrt((k + 1/2) / n), turned by the
// golden angle pi (3 - sqrt 5) per point and by `rotation` (radians) as a whole (Vogel 1979).
// Uniform in area: the first k points fill the disk of area pi (k / n) up to half a point.
std::array<double, 2> fibonacciDiskPoint(int k, int n, double rotation);

// Solid angle of the spherical triangle (a, b, c), unit vertices counter-clockwise about its
// inside (negative when clockwise): Van Oosterom & Strackee (1983).
double triangleSolidAngle(const D3& a, const D3& b, const D3& c);

// Solid angle of the rectangle [x0, x1] x [y0, y1] of a tangent plane at unit distance (a
// gnomonic projection: a cube-face region, a light's frame cell), exact.
double frameRectSolidAngle(double x0, double x1, double y0, double y1);

// n directions uniform in solid angle over the cap of cosine `cosAlpha` about `direction` (any
// length, normalized here): a spherical Fibonacci set, ring k at cos(theta) = 1 - (1 - cos
// alpha)(k + 1/2) / n, golden-angle turns, all turned by `rotation` about the axis. The angle is
// measured from ex = normalize(ref x w), ref = +y unless w is within acos(0.99) of it (then +x),
// the frame renderer.cpp's lightFrame builds. Float arithmetic throughout. Empty for n < 1.
std::vector<std::array<float, 3>> sphericalFibonacciCap(const std::array<float, 3>& direction,
                                                        float cosAlpha, int n, float rotation);

// Arvo's area-preserving map of the unit square onto a spherical triangle (Arvo 1995,
// "Stratified sampling of spherical triangles", SIGGRAPH, Fig. 2): u1 picks the sub-triangle
// (A, B, C^) of solid angle u1 * area, u2 the point along the arc from B to C^ by
// cos(arc) = 1 - u2 (1 - C^.B). A, B, C: unit vertices, counter-clockwise; area: the triangle's
// solid angle (triangleSolidAngle). A uniform (u1, u2) gives a direction uniform in solid angle.
D3 arvoTrianglePoint(const D3& A, const D3& B, const D3& C, double area, double u1, double u2);

// n directions stratified and uniform in solid angle over a convex spherical polygon (vertices:
// any length, counter-clockwise, at least 3; empty otherwise or for n < 1): the fan triangles from
// vertex 0, each point of the Fibonacci lattice ((k + 1/2) / n, frac(k / golden ratio)) sent
// through the fan's cumulative solid angles by its first coordinate and through Arvo's map in its
// triangle. `rotation` (radians) shifts the lattice's second coordinate by rotation / (2 pi)
// (mod 1): a polygon is not symmetric about an axis, and this moves every point inside it as a
// turn moves a cap's.
std::vector<std::array<float, 3>> sphericalPolygonSamples(
    const std::vector<std::array<float, 3>>& vertices, int n, float rotation);

}  // namespace penumbra::detail
