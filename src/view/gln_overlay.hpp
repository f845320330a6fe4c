#pragma once
/// @file gln_overlay.hpp
/// @brief Which GLN network loops the render overlay draws (scene key render.overlays.gln_loops,
/// docs/rendering.md "Overlays"). The loops are the object loops of collide/gln_network.hpp,
/// evaluated on the frame's lattice positions exactly as the contact detection evaluates them.

#include "base/types.hpp"
#include "collide/gln_network.hpp"
#include "sim/scene.hpp"

#include <string>
#include <vector>

namespace dgv {

/// Whether the closed loop c faces the point `eye`: its vector area (½ Σ c_i × c_{i+1}) points
/// towards eye from the loop's centroid. The network's rings run counter-clockwise about the
/// body's outward normal, so a ring faces the eye when it is on the side of the body seen from it.
bool loopFacesPoint(const ClosedCurve& c, const Vec3& eye);

/// The loops of `network` at positions x (#P), in ring order: Contact: the fine rings of the
/// points p with contact[p] != 0 (contact empty or shorter than #P: those points count as
/// outside R); All: every fine ring; Coarse: every coarse ring. With `eye`, All and Coarse keep
/// only the loops facing it (loopFacesPoint); Contact keeps them all (R is seldom on the side
/// the camera sees).
std::vector<ClosedCurve> glnOverlayLoops(const GlnNetwork& network, GlnLoopSet set, const std::vector<Vec3>& x,
                                         const std::vector<unsigned char>& contact, const Vec3* eye = nullptr);

}  // namespace dgv
