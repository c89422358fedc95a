#pragma once
// The rig schema: one table row per property of a light or of the rig (path, type, unit, range,
// default, keyframable, what a change invalidates). It is the one source of truth behind
//   - JSON decoding and validation (Codec: rigFromJson, applyChange, keys),
//   - the JSON a rig is written as (toJson),
//   - the command-line client's property paths (dfb-client properties, parseAssignment),
//   - the engine's cache keys (sameInputs: which edits re-render a shadow map, re-shade, rescale),
//   - the browser's property rows and slider ranges (GET /v1/schema, schemaJson()),
//   - the property table of docs/protocol.md (markdownTable(), checked by a test).
// Adding a light property = adding a field to Light (Rig.h) and one row in Schema.cpp.

#include <dfb/core/Result.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace dfb::protocol {

/// The value a property takes (and so how it is validated and which widget edits it).
enum class PropType {
    Number,    ///< a finite number in [min, max]
    Integer,   ///< an integer in [min, max]
    Boolean,
    String,
    Enum,      ///< one of `values`
    Vec3,      ///< [x, y, z], each in [min, max]
    Color,     ///< linear [r, g, b], each in [min, max]
    Direction, ///< [x, y, z], not zero; normalised on set
    Numbers,   ///< an array of numbers in [min, max]: `size` of them, or one per chain point
    IdList,    ///< an array of object ids (1-based)
    Points,    ///< an array of [a, b, c] points (a BendyLight's chain)
    Colors,    ///< an array of [r, g, b] (one per chain point)
    Keys,      ///< keyframe operations (keys, key, unkey)
    Groups,    ///< the rig's light groups: [{"name", "lights": [names]}]
};

/// What a change of the property makes the engine redo, cheapest first (DESIGN section 6):
/// nothing (None), only the final sum and tone map (Composite), only a rescale of the light's
/// cached image (Scale), the light's shading (Shade), or its shadow map and shading (Shadow).
enum class Invalidates { None, Composite, Scale, Shade, Shadow };

/// What switching a light to an area light caps its shadowMapSize at: the size of each map of its
/// grid (Light::shadowGrid).
constexpr int AREA_DEFAULT_MAP_SIZE = 512;

/// Light types as a bit mask (Property::appliesTo).
enum LightTypeBits : unsigned {
    APPLIES_SPOT = 1u << unsigned(LightType::Spot),
    APPLIES_BENDY = 1u << unsigned(LightType::Bendy),
    APPLIES_DIRECTIONAL = 1u << unsigned(LightType::Directional),
    APPLIES_POINT = 1u << unsigned(LightType::Point),
    APPLIES_AREA = 1u << unsigned(LightType::Area),
    APPLIES_BENT_AREA = 1u << unsigned(LightType::BentArea),
    APPLIES_ENVIRONMENT = 1u << unsigned(LightType::Environment),
    APPLIES_ALL = APPLIES_SPOT | APPLIES_BENDY | APPLIES_DIRECTIONAL | APPLIES_POINT | APPLIES_AREA | APPLIES_BENT_AREA |
                  APPLIES_ENVIRONMENT,
};

struct Property;
/// Validates `v` and stores it in `l`; `index` is the element index of an indexed row ("cp[3]": 3),
/// else -1.
using PropertySetter = Status (*)(const Property& p, Light& l, const nlohmann::json& v, const std::string& path, int index);

/// One row of the schema. A light row's default is its value in a default-constructed Light (Rig.h);
/// a rig row's, in a default Rig.
struct Property {
    const char* path = "";    ///< relative to the light ("intensity"), or rig-level; "cp[]" = indexed element
    const char* label = "";   ///< as the browser shows it
    PropType type = PropType::Number;
    const char* unit = "";    ///< "" when none
    double min = 0, max = 0;  ///< validation range (per component for vectors)
    double uiMin = 0, uiMax = 0, step = 0; ///< the browser's slider range (0, 0 = none)
    bool keyframable = false;
    Invalidates invalidates = Invalidates::None;
    unsigned appliesTo = APPLIES_ALL;
    int size = 0;             ///< fixed length of a Numbers value (0 = one per chain point)
    const char* indexOf = ""; ///< element rows: the list row they index ("controlPoints")
    int indexBase = 0;        ///< element rows: the index of the list's first element ("cp[1]" for cp[])
    bool readOnly = false;    ///< written by the server only
    const char* values = "";  ///< Enum: the choices, comma-separated
    const char* valueDoc = "";///< docs/protocol.md "value" column
    const char* doc = "";     ///< docs/protocol.md "unit, range" column
    PropertySetter set = nullptr; ///< validates and stores; null for rig-level rows (Codec sets those)
    /// Compares the property of two lights (for cache keys); null for element and keyframe rows,
    /// whose values are compared through their list rows.
    bool (*same)(const Light& a, const Light& b) = nullptr;
    /// Shadow-level rows whose shadow map depends only on a coarser value than the property:
    /// true when a and b give the same shadow map (null: `same` decides).
    bool (*sameShadow)(const Light& a, const Light& b) = nullptr;
    /// Whether toJson writes the property for this light (null: always).
    bool (*present)(const Light& l) = nullptr;
    /// The property's JSON value for toJson (null for element, keyframe and rig rows).
    nlohmann::json (*get)(const Light& l) = nullptr;
};

/// Every light property, in the order docs and the browser list them.
const std::vector<Property>& lightProperties();
/// The rig-level properties (exposure, viewTransform, time).
const std::vector<Property>& rigProperties();

/// The light row of `prop` ("intensity", "cp[3]" -> the "cp[]" row), or null. `index` receives
/// the element index (-1 without one); a malformed index ("cp[x]", "cp[]", "cp[1") gives null
/// and index -2.
const Property* findLightProperty(std::string_view prop, int* index = nullptr);
/// The rig-level row of `path`, or null.
const Property* findRigProperty(std::string_view path);

/// Half-angle of a spot light's shadow frustum in degrees: the cone plus a degree, rounded up to
/// 5 degrees, so that dragging the cone re-shades without re-rendering the shadow map until it
/// crosses a step; at most 86 (a perspective projection degenerates towards 90). The engine's
/// frustum and the schema's cache key both use it (docs/lighting.md).
float shadowHalfAngleDeg(const Light& light);

/// True when `a` and `b` agree on every property of their type whose change invalidates `level`
/// or more. sameInputs(a, b, Shadow): the same shadow map; (.., Shade): the same shaded image
/// up to a rescale. Derived from the schema rows: no field is listed by hand anywhere else.
bool sameInputs(const Light& a, const Light& b, Invalidates level);

std::string_view toString(PropType t);
std::string_view toString(Invalidates i);
std::string lightTypeName(LightType t);
/// "spot" -> Spot, ...; nothing for an unknown name.
std::optional<LightType> lightTypeFromName(std::string_view name);
/// Whether `name` is a valid name of a light, snapshot or saved rig: 1-64 characters of letters,
/// digits, '_' or '-' (NAME_RULE says so in messages).
bool isValidName(const std::string& name);
inline constexpr const char* NAME_RULE = "a name is 1-64 characters of letters, digits, '_' or '-'";

/// The schema as served at GET /v1/schema (docs/protocol.md "Schema").
nlohmann::json schemaJson();
/// The property-path table of docs/protocol.md, generated from the rows.
std::string markdownTable();

} // namespace dfb::protocol
