// Physical bounds shared by the scene's simulations (docs/reliability.md): no
// scene file can make sim_node step without end or stop answering SIGINT.
#pragma once

namespace hullpipe {

/// max_substep of the scene, cloth and particles, seconds: at most 1e4 substeps
/// per simulated second (a 1 ns substep once made one frame take hours), and no
/// coarser than 0.1 s (past that nothing tunnels less than without substeps).
constexpr double kMinSubstepS = 1e-4, kMaxSubstepS = 0.1;

/// A scene file's size: 1 MiB (scenes are a few KB; a model's geometry is its
/// own file). A 70-MB list once took gigabytes to parse, past SIGINT.
constexpr long long kMaxSceneFileBytes = 1LL << 20;

/// Balls in a scene, and their triangles together (20 * 4^subdivisions each):
/// 256 and 2^20 (51 balls at subdivision 5, 204 at 4). 5000 balls at
/// subdivision 5 (1e8 triangles) once took 2.5 GB and ignored SIGINT.
constexpr int kMaxBalls = 256;
constexpr long long kMaxBallTriangles = 1LL << 20;

}  // namespace hullpipe
