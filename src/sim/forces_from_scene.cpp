#include "sim/forces_from_scene.hpp"

#include "base/errors.hpp"

namespace dgv {

ForceTerm forceTermFromScene(const ForceDesc& d) {
    ForceTerm t;
    switch (d.type) {
        case ForceType::Gravity:
            t.kind = ForceKind::Gravity;
            break;
        case ForceType::Attractor:
            t.kind = ForceKind::Attractor;
            break;
        case ForceType::Vortex:
            t.kind = ForceKind::Vortex;
            break;
        case ForceType::Torsion:
            t.kind = ForceKind::Torsion;
            break;
        case ForceType::Burst:
            t.kind = ForceKind::Burst;
            break;
        case ForceType::Wind:
            t.kind = ForceKind::Wind;
            break;
    }
    t.strength.keys = d.strength.keys;
    t.direction = d.direction;
    t.centre = d.position;
    t.axis = d.axis;
    t.radius = d.radius;
    t.softening = d.softening;
    t.falloff = d.falloff;
    t.turbulence = d.turbulence;
    t.scale = d.scale;
    t.seed = d.seed;
    t.modes = d.modes;
    return t;
}

ForceField forceFieldFromScene(const std::vector<ForceDesc>& forces, const std::string& sceneFile) {
    ForceField field;
    for (std::size_t i = 0; i < forces.size(); ++i) {
        const ForceTerm t = forceTermFromScene(forces[i]);
        const auto problems = t.validate();
        if (!problems.empty()) {
            const std::string& p = problems.front();
            const auto colon = p.find(':');
            std::string key = p.substr(0, colon);
            if (key == "centre") key = "position";
            throw InputError(sceneFile, "forces[" + std::to_string(i) + "]." + key,
                             colon == std::string::npos ? p : p.substr(colon + 2));
        }
        field.add(t);
    }
    return field;
}

}  // namespace dgv
