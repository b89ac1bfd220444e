// Physical bounds shared by the scene's simulations (docs/reliability.md): no
// scene file can make sim_node step without end or stop answering SIGINT.
#pragma once

namespace hullpipe {

/// max_substep of the scene, cloth and particles, seconds: at most 1e4 substeps
/// per simulated second (a 1 ns substep once made one frame take hours), and no
/// coarser than 0.1 s (past that nothing tunnels less than without substeps).
constexpr double kMinSubstepS = 1e-4, kMaxSubstepS = 0.1;

}  // namespace hullpipe
