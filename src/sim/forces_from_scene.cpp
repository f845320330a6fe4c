#include "sim/forces_from_scene.hpp"

#include "base/errors.hpp"

namespace dgv {

ForceField forceFieldFromScene(const std::vector<ForceTerm>& forces, const std::string& sceneFile) {
    ForceField field;
    for (std::size_t i = 0; i < forces.size(); ++i) {
        const ForceTerm& t = forces[i];
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
