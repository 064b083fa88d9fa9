// The face-varying channel's tables (docs/face-varying.md): one step's rows over face-varying
// vertices with the positions' row builder, and the finest level's faces.
#include "psub/stencils.h"

#include "step_rows.h"

namespace psub {

const char* uvLinearName(UvLinear linear) { return linear == UvLinear::All ? "all" : "boundaries"; }

void appendFaceVaryingLevel(PerLevelTable& table, const FaceVaryingLevel& level, bool paired,
                            UvLinear linear, Rules rules, std::span<const char> inputCorners) {
    appendStepRows(table, level.faces, level.connectivity, paired || linear == UvLinear::All, false,
                   level.split, rules, inputCorners);
}

void setFaceVaryingFaces(FaceVaryingTable& table, const FaceVaryingLevel& finest) {
    table.faceOffsets = finest.faces.offsets;
    table.faceVerts = finest.positionOf;
    table.faceValues = finest.faces.verts;
}

FaceVaryingTable buildFaceVaryingTable(const Hierarchy& hierarchy, const Mesh& mesh, UvLinear linear, Rules rules) {
    FaceVaryingTable table;
    table.width = mesh.uv.width;
    table.perLevel.controlCount = mesh.uv.valueCount();
    FaceVaryingLevel level = faceVaryingBase(mesh, hierarchy.levels.front().connectivity);
    const std::vector<char> corners = inputCorners(level.faces, level.connectivity, rules);
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k) {
        appendFaceVaryingLevel(table.perLevel, level, hierarchy.preprocessed && k == 1, linear, rules, corners);
        level = refineFaceVarying(level, hierarchy.levels[k - 1]);
    }
    setFaceVaryingFaces(table, level);
    return table;
}

}  // namespace psub
