// The one JSON writer of psub's commands: nlohmann-json, fields kept in the order written,
// non-finite numbers written as null, and any text (paths, names) escaped properly.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace psub::cli {

using Json = nlohmann::ordered_json;

// `value` as JSON text on one line, with a space after each ':' and ',' (the layout psub's
// JSON has always had); strings and numbers are nlohmann's own text. Invalid UTF-8 in a
// string (a path in another encoding) is replaced by U+FFFD, never an exception.
inline std::string jsonText(const Json& value) {
    const auto scalar = [](const Json& v) { return v.dump(-1, ' ', false, Json::error_handler_t::replace); };
    std::string out;
    if (value.is_object()) {
        for (const auto& [key, item] : value.items()) out += (out.empty() ? "" : ", ") + scalar(Json(key)) + ": " + jsonText(item);
        return "{" + out + "}";
    }
    if (value.is_array()) {
        for (const Json& item : value) out += (out.empty() ? "" : ", ") + jsonText(item);
        return "[" + out + "]";
    }
    return scalar(value);
}

}  // namespace psub::cli
