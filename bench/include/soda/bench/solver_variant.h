// bench/ — solver variants for diagnosis (`soda stress --variant`): a list of
// changes to a Bullet world's solver settings and bodies, applied after the
// world is built, so that one case can be measured under settings the scene
// format does not carry (docs/stress.md "Why each case fails at the
// defaults"). Diagnosis only: a variant may break the exactness contract
// (e.g. `rand`), and is never used by `soda run`.
#pragma once

#include <memory>
#include <string>

class btDiscreteDynamicsWorld;
class btConstraintSolver;

namespace soda {

/// Applies `variant` ("key=value,key,...", "" for none) to `world`.
/// Keys: ws=F (warm-starting factor), nows (no warm starting), split=0|1,
/// erp=F, erp2=F (split-impulse ERP), spthr=F (split-impulse penetration
/// threshold), cpt=F (contact processing threshold of every body),
/// nosleep (no deactivation), fdir (2 friction directions + caching),
/// interleave (contact and friction rows interleaved), rand (random row
/// order), sor=F, slop=F (linear slop), fric=F (every body's friction),
/// nncg (Bullet's NNCG solver; kept alive in `solver_out`, which must
/// outlive the world). Throws std::invalid_argument naming an unknown key.
void apply_solver_variant(btDiscreteDynamicsWorld& world, const std::string& variant,
                          std::unique_ptr<btConstraintSolver>& solver_out);

}  // namespace soda
