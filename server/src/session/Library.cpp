#include "session/Library.h"

#include "session/Journal.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Messages.h>
#include <dfb/protocol/Schema.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>

namespace dfb {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

constexpr const char* SNAPSHOTS = "snapshots";
constexpr const char* RIGS = "rigs";
// A record or an image larger than this is not one the server wrote (a 16k frame at quality 85
// is ~40 MB): refused on load instead of read into memory.
constexpr uintmax_t MAX_FILE_BYTES = uintmax_t(256) << 20;

Status checkName(const std::string& what, const std::string& name) {
    if (!protocol::isValidName(name)) {
        return makeError(ErrorCode::InvalidValue, what + " name '" + name.substr(0, 64) + "': " + protocol::NAME_RULE);
    }
    return okStatus();
}

json entryJson(const Library::Entry& e) {
    return json{{"name", e.name}, {"rigVersion", e.rigVersion}, {"by", e.by}, {"time", e.time}, {"rig", e.rig}};
}

// Reads a record (the inverse of entryJson); `name` is the file's stem, which must agree.
Result<Library::Entry> entryFromJson(const json& j, const std::string& name) {
    Library::Entry e;
    try {
        e.name = j.at("name").get<std::string>();
        e.rigVersion = j.at("rigVersion").get<uint64_t>();
        e.by = j.at("by").get<std::string>();
        e.time = j.at("time").get<std::string>();
        e.rig = j.at("rig");
    } catch (const json::exception& ex) {
        return makeError(ErrorCode::InvalidFile, std::string("not a library record: ") + ex.what());
    }
    if (e.name != name) return makeError(ErrorCode::InvalidFile, "the record is named '" + e.name + "', its file '" + name + "'");
    if (auto r = protocol::rigFromJson(e.rig); !r) return makeError(ErrorCode::InvalidFile, "its rig: " + r.error().message);
    return e;
}

Library::Entry makeEntry(const std::string& name, const Rig& rig, const std::string& by) {
    Library::Entry e;
    e.name = name;
    e.rigVersion = rig.version;
    e.by = by;
    e.time = Journal::utcTimestamp();
    e.rig = protocol::toJson(rig);
    return e;
}

// Removes an entry's files; the record first, so that a crash part way leaves no half entry
// (images without a record are ignored on load and overwritten by the next of that name).
Status removeFiles(const std::vector<fs::path>& files) {
    for (const fs::path& f : files) {
        std::error_code ec;
        fs::remove(f, ec);
        if (ec) return makeError(ErrorCode::IoError, f.string() + ": cannot remove: " + ec.message());
    }
    return okStatus();
}

} // namespace

Result<std::unique_ptr<Library>> Library::open(const fs::path& dir, std::vector<std::string>* report) {
    std::unique_ptr<Library> lib(new Library(dir));
    if (dir.empty()) return lib;
    std::error_code ec;
    for (const char* sub : {SNAPSHOTS, RIGS}) {
        fs::create_directories(dir / sub, ec);
        if (ec) return makeError(ErrorCode::IoError, (dir / sub).string() + ": cannot create: " + ec.message());
    }
    auto skip = [&](const fs::path& p, const std::string& why) {
        if (report) report->push_back(p.string() + ": skipped: " + why);
    };
    for (const char* sub : {SNAPSHOTS, RIGS}) {
        std::vector<fs::path> records;
        for (const auto& f : fs::directory_iterator(dir / sub, ec)) {
            if (f.path().extension() == ".json") records.push_back(f.path());
        }
        std::sort(records.begin(), records.end());
        for (const fs::path& p : records) {
            const std::string name = p.stem().string();
            if (!protocol::isValidName(name)) {
                skip(p, protocol::NAME_RULE);
                continue;
            }
            auto j = Journal::readJsonBounded(p, MAX_FILE_BYTES);
            if (!j) {
                skip(p, j.error().message);
                continue;
            }
            auto e = entryFromJson(j.value(), name);
            if (!e) {
                skip(p, e.error().message);
                continue;
            }
            if (std::string(sub) == RIGS) {
                if (lib->mRigs.size() < MAX_RIGS) lib->mRigs.emplace(name, std::move(e.value()));
                continue;
            }
            auto s = std::make_shared<Snapshot>();
            static_cast<Entry&>(*s) = std::move(e.value());
            auto image = Journal::readFileBounded(dir / sub / (name + ".jpg"), MAX_FILE_BYTES);
            auto thumb = Journal::readFileBounded(dir / sub / (name + ".thumb.jpg"), MAX_FILE_BYTES);
            if (!image || !thumb) {
                skip(p, "its image: " + (!image ? image.error().message : thumb.error().message));
                continue;
            }
            s->width = j->value("width", 0);
            s->height = j->value("height", 0);
            s->image = std::make_shared<const std::string>(std::move(image.value()));
            s->thumbnail = std::make_shared<const std::string>(std::move(thumb.value()));
            if (lib->mSnapshots.size() < MAX_SNAPSHOTS) lib->mSnapshots.emplace(name, std::move(s));
        }
    }
    return lib;
}

json Library::summary(const Entry& e) {
    return json{{"name", e.name}, {"rigVersion", e.rigVersion}, {"by", e.by}, {"time", e.time},
                {"lights", e.rig.contains("lights") ? e.rig["lights"].size() : size_t(0)}};
}

Result<json> Library::addSnapshot(const std::string& name, const Rig& rig, const std::string& by, std::string frameJpeg, int width,
                                  int height) {
    if (auto s = checkName("snapshot", name); !s) return s.error();
    if (mSnapshots.count(name)) {
        return makeError(ErrorCode::Conflict, "a snapshot named '" + name + "' exists: pick another name or delete it first");
    }
    if (mSnapshots.size() >= MAX_SNAPSHOTS) {
        return makeError(ErrorCode::LimitExceeded, "the session has " + std::to_string(MAX_SNAPSHOTS) +
                                                       " snapshots, the most it keeps: delete one first");
    }
    auto thumb = jpegThumbnail(reinterpret_cast<const uint8_t*>(frameJpeg.data()), frameJpeg.size(), THUMBNAIL_WIDTH);
    if (!thumb) return thumb.error();
    auto s = std::make_shared<Snapshot>();
    static_cast<Entry&>(*s) = makeEntry(name, rig, by);
    s->width = width;
    s->height = height;
    s->image = std::make_shared<const std::string>(std::move(frameJpeg));
    s->thumbnail = std::make_shared<const std::string>(thumb->begin(), thumb->end());
    if (persistent()) {
        const fs::path base = mDir / SNAPSHOTS / name;
        json record = entryJson(*s);
        record["width"] = s->width;
        record["height"] = s->height;
        // Images first, the record last: a record on disk always has its images.
        Status st = Journal::writeFileDurably(base.string() + ".jpg", *s->image);
        if (st) st = Journal::writeFileDurably(base.string() + ".thumb.jpg", *s->thumbnail);
        if (st) st = Journal::writeFileDurably(base.string() + ".json", protocol::dump(record, 2));
        if (!st) {
            (void)removeFiles({base.string() + ".json", base.string() + ".jpg", base.string() + ".thumb.jpg"});
            return st.error();
        }
    }
    json out = summary(*s);
    out["width"] = s->width;
    out["height"] = s->height;
    mSnapshots.emplace(name, std::move(s));
    return out;
}

Status Library::removeSnapshot(const std::string& name) {
    if (!mSnapshots.count(name)) return makeError(ErrorCode::MissingData, "no snapshot named '" + name.substr(0, 64) + "'");
    if (persistent()) {
        const fs::path base = mDir / SNAPSHOTS / name;
        if (auto s = removeFiles({base.string() + ".json", base.string() + ".jpg", base.string() + ".thumb.jpg"}); !s) return s;
    }
    mSnapshots.erase(name);
    return okStatus();
}

Result<std::shared_ptr<const Library::Snapshot>> Library::snapshot(const std::string& name) const {
    auto it = mSnapshots.find(name);
    if (it == mSnapshots.end()) return makeError(ErrorCode::MissingData, "no snapshot named '" + name.substr(0, 64) + "'");
    return it->second;
}

Result<json> Library::saveRig(const std::string& name, const Rig& rig, const std::string& by) {
    if (auto s = checkName("rig", name); !s) return s.error();
    if (!mRigs.count(name) && mRigs.size() >= MAX_RIGS) {
        return makeError(ErrorCode::LimitExceeded, "the session has " + std::to_string(MAX_RIGS) +
                                                       " saved rigs, the most it keeps: delete one first");
    }
    Entry e = makeEntry(name, rig, by);
    if (persistent()) {
        if (auto s = Journal::writeFileDurably(mDir / RIGS / (name + ".json"), protocol::dump(entryJson(e), 2)); !s) return s.error();
    }
    json out = summary(e);
    mRigs[name] = std::move(e);
    return out;
}

Status Library::removeRig(const std::string& name) {
    if (!mRigs.count(name)) return makeError(ErrorCode::MissingData, "no saved rig named '" + name.substr(0, 64) + "'");
    if (persistent()) {
        if (auto s = removeFiles({mDir / RIGS / (name + ".json")}); !s) return s;
    }
    mRigs.erase(name);
    return okStatus();
}

Result<Library::Entry> Library::savedRig(const std::string& name) const {
    auto it = mRigs.find(name);
    if (it == mRigs.end()) return makeError(ErrorCode::MissingData, "no saved rig named '" + name.substr(0, 64) + "'");
    return it->second;
}

json Library::list() const {
    auto sorted = [](std::vector<json> v) {
        std::sort(v.begin(), v.end(), [](const json& a, const json& b) {
            return std::tie(a["time"].get_ref<const std::string&>(), a["name"].get_ref<const std::string&>()) <
                   std::tie(b["time"].get_ref<const std::string&>(), b["name"].get_ref<const std::string&>());
        });
        return json(v);
    };
    std::vector<json> snaps, rigs;
    for (const auto& [name, s] : mSnapshots) {
        json j = summary(*s);
        j["width"] = s->width;
        j["height"] = s->height;
        snaps.push_back(std::move(j));
    }
    for (const auto& [name, e] : mRigs) rigs.push_back(summary(e));
    return json{{"snapshots", sorted(std::move(snaps))}, {"rigs", sorted(std::move(rigs))}};
}

} // namespace dfb
