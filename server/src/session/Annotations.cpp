#include "session/Annotations.h"

#include "session/Journal.h"

#include <dfb/protocol/Json.h>

#include <algorithm>

namespace dfb {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// A record is a few kilobytes (2000 points, 2000 characters): a much larger file is not one the
// server wrote, and is refused on load instead of read into memory.
constexpr uintmax_t MAX_RECORD_BYTES = uintmax_t(1) << 20;

// The record's file: ID.json, the id in decimal.
fs::path fileOf(const fs::path& dir, uint64_t id) { return dir / (std::to_string(id) + ".json"); }

// Reads a record (the inverse of Annotations::toJson); `id` is the file's stem, which must agree.
Result<Annotations::Annotation> fromJson(const json& j, uint64_t id) {
    Annotations::Annotation a;
    try {
        a.id = j.at("id").get<uint64_t>();
        a.rigVersion = j.at("rigVersion").get<uint64_t>();
        a.by = j.at("by").get<std::string>();
        a.time = j.at("time").get<std::string>();
        a.resolved = j.at("resolved").get<bool>();
        a.resolvedBy = j.value("resolvedBy", std::string());
        a.resolvedTime = j.value("resolvedTime", std::string());
    } catch (const json::exception& ex) {
        return makeError(ErrorCode::InvalidFile, std::string("not an annotation record: ") + ex.what());
    }
    if (a.id != id) return makeError(ErrorCode::InvalidFile, "the record has id " + std::to_string(a.id) + ", its file " + std::to_string(id));
    // The shape by the same checks as a new one: a hand-edited record is held to the protocol.
    json shape = json::object();
    for (const char* f : {"kind", "points", "text", "color"}) {
        if (j.contains(f)) shape[f] = j[f];
    }
    auto s = protocol::annotationFromJson(shape, "annotation");
    if (!s) return makeError(ErrorCode::InvalidFile, s.error().message);
    a.shape = std::move(s.value());
    return a;
}

} // namespace

Result<std::unique_ptr<Annotations>> Annotations::open(const fs::path& dir, std::vector<std::string>* report) {
    std::unique_ptr<Annotations> store(new Annotations(dir));
    if (dir.empty()) return store;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return makeError(ErrorCode::IoError, dir.string() + ": cannot create: " + ec.message());
    auto skip = [&](const fs::path& p, const std::string& why) {
        if (report) report->push_back(p.string() + ": skipped: " + why);
    };
    std::vector<std::pair<uint64_t, fs::path>> records;
    for (const auto& f : fs::directory_iterator(dir, ec)) {
        const fs::path& p = f.path();
        if (p.extension() != ".json") continue;
        const std::string stem = p.stem().string();
        if (stem.empty() || stem.size() > 19 || stem.find_first_not_of("0123456789") != std::string::npos) {
            skip(p, "not an annotation's file (ID.json)");
            continue;
        }
        records.emplace_back(std::stoull(stem), p);
    }
    if (ec) return makeError(ErrorCode::IoError, dir.string() + ": cannot list: " + ec.message());
    std::sort(records.begin(), records.end());
    for (const auto& [id, p] : records) {
        auto j = Journal::readJsonBounded(p, MAX_RECORD_BYTES);
        if (!j) {
            skip(p, j.error().message);
            continue;
        }
        auto a = fromJson(j.value(), id);
        if (!a) {
            skip(p, a.error().message);
            continue;
        }
        if (store->mById.size() >= MAX_ANNOTATIONS) {
            skip(p, "the session keeps at most " + std::to_string(MAX_ANNOTATIONS) + " annotations");
            continue;
        }
        if (store->mPoints + a->shape.points.size() > MAX_TOTAL_POINTS) {
            skip(p, "the session's annotations hold at most " + std::to_string(MAX_TOTAL_POINTS) + " points together");
            continue;
        }
        store->mPoints += a->shape.points.size();
        store->mById.emplace(id, std::move(a.value()));
    }
    // Past every id on disk, damaged ones included: a new annotation never takes the file of one
    // that was skipped. (A deleted annotation's id can come back after a restart when it was the
    // newest; nothing refers to a deleted one.)
    if (!records.empty()) store->mNextId = records.back().first + 1;
    return store;
}

json Annotations::toJson(const Annotation& a) {
    json pts = json::array();
    for (const auto& p : a.shape.points) pts.push_back({p[0], p[1]});
    json j{{"id", a.id},       {"kind", a.shape.kind}, {"points", pts},          {"text", a.shape.text},
           {"rigVersion", a.rigVersion}, {"by", a.by}, {"time", a.time}, {"resolved", a.resolved}};
    if (!a.shape.color.empty()) j["color"] = a.shape.color;
    if (a.resolved) {
        j["resolvedBy"] = a.resolvedBy;
        j["resolvedTime"] = a.resolvedTime;
    }
    return j;
}

Status Annotations::save(const Annotation& a) const {
    if (!persistent()) return okStatus();
    return Journal::writeFileDurably(fileOf(mDir, a.id), protocol::dump(toJson(a), 2));
}

Result<json> Annotations::add(const protocol::AnnotateMessage& shape, int width, int height, uint64_t rigVersion, const std::string& by) {
    // Pixel edges included: a pin on the last column's right edge is still on the frame.
    for (size_t i = 0; i < shape.points.size(); ++i) {
        const auto& p = shape.points[i];
        if (p[0] < 0 || p[0] > width || p[1] < 0 || p[1] > height) {
            return makeError(ErrorCode::InvalidValue, "annotation.points[" + std::to_string(i) + "]: [" + protocol::dump(json(p[0])) + ", " +
                                                          protocol::dump(json(p[1])) + "] is outside the " + std::to_string(width) + "x" +
                                                          std::to_string(height) + " shot (0 <= x <= " + std::to_string(width) +
                                                          ", 0 <= y <= " + std::to_string(height) + ")");
        }
    }
    if (mById.size() >= MAX_ANNOTATIONS) {
        return makeError(ErrorCode::LimitExceeded, "the session has " + std::to_string(MAX_ANNOTATIONS) +
                                                       " annotations, the most it keeps: delete resolved ones first");
    }
    if (mPoints + shape.points.size() > MAX_TOTAL_POINTS) {
        return makeError(ErrorCode::LimitExceeded, "annotation.points: the session's annotations hold " + std::to_string(mPoints) +
                                                       " points, and " + std::to_string(shape.points.size()) + " more would pass the " +
                                                       std::to_string(MAX_TOTAL_POINTS) + " they may hold together: delete some first");
    }
    Annotation a;
    a.id = mNextId;
    a.shape = shape;
    a.shape.seq = 0;
    a.rigVersion = rigVersion;
    a.by = by;
    a.time = Journal::utcTimestamp();
    if (auto s = save(a); !s) return s.error();
    ++mNextId;
    mPoints += a.shape.points.size();
    json out = toJson(a);
    mById.emplace(a.id, std::move(a));
    return out;
}

Result<json> Annotations::setResolved(uint64_t id, bool resolved, const std::string& by) {
    auto it = mById.find(id);
    if (it == mById.end()) return makeError(ErrorCode::MissingData, "no annotation " + std::to_string(id));
    Annotation a = it->second;
    if (resolved && !a.resolved) {
        a.resolvedBy = by;
        a.resolvedTime = Journal::utcTimestamp();
    } else if (!resolved) {
        a.resolvedBy.clear();
        a.resolvedTime.clear();
    }
    a.resolved = resolved;
    // The file first: memory changes only when the change is kept.
    if (auto s = save(a); !s) return s.error();
    it->second = std::move(a);
    return toJson(it->second);
}

Status Annotations::remove(uint64_t id) {
    auto it = mById.find(id);
    if (it == mById.end()) return makeError(ErrorCode::MissingData, "no annotation " + std::to_string(id));
    if (persistent()) {
        std::error_code ec;
        fs::remove(fileOf(mDir, id), ec);
        if (ec) return makeError(ErrorCode::IoError, fileOf(mDir, id).string() + ": cannot remove: " + ec.message());
    }
    mPoints -= it->second.shape.points.size();
    mById.erase(it);
    return okStatus();
}

json Annotations::list() const {
    json out = json::array();
    for (const auto& [id, a] : mById) out.push_back(toJson(a));
    return out;
}

} // namespace dfb
