#include "session/Session.h"

#include <dfb/core/Check.h>
#include <dfb/protocol/Schema.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/FinalRender.h>
#include <dfb/server/ImageCodec.h>

#include <dfb/protocol/Json.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace dfb {

namespace {
using json = nlohmann::json;

// The server, not clients, says what is doubtful about a BendyLight's chain (paper section 7).
void updateWarnings(Rig& rig) {
    for (Light& l : rig.lights) l.warning = chainWarning(l);
}

std::vector<protocol::Change> changesFromJson(const json& arr) {
    std::vector<protocol::Change> out;
    if (!arr.is_array()) return out;
    for (const json& c : arr) {
        if (c.is_object() && c.contains("path") && c["path"].is_string() && c.contains("value")) {
            out.push_back({c["path"].get<std::string>(), c["value"]});
        }
    }
    return out;
}

// Two paths touch the same property when one is the other or a part of it ("key" and
// "key.position", "key.controlPoints" and "key.cp[2]" are both reported as the light's).
bool overlaps(const std::string& a, const std::string& b) {
    auto lightOf = [](const std::string& p) { return p.substr(0, p.find('.')); };
    if (a == b) return true;
    const std::string la = lightOf(a), lb = lightOf(b);
    if (la != lb) return false;
    auto prop = [](const std::string& p) {
        const size_t dot = p.find('.');
        std::string s = dot == std::string::npos ? "" : p.substr(dot + 1);
        s = s.substr(0, s.find('['));
        if (s == "cp") s = "controlPoints";
        if (s == "r") s = "radii";
        if (s == "cpColor") s = "colors";
        return s;
    };
    return prop(a) == prop(b) || prop(a) == "name" || prop(b) == "name";
}

// The edit's changes with every light whose chain would fold limited (limitChainEdit): a change
// of a limited light's chain property takes the limited value in place (the path the client
// sent, so its handle lands where the server stopped it); whatever else still differs from the
// limited light is appended as the whole property. Fills `report` per limited light.
std::vector<protocol::Change> limitFolds(const Rig& before, std::vector<protocol::Change> changes, json& report) {
    // Most edits touch no chain (intensity, colour, a spot's aim): no trial application then. A
    // change of a light's type to a chained one has no "before" chain to limit against either.
    const bool chained = std::any_of(changes.begin(), changes.end(), [&](const protocol::Change& c) {
        const Light* l = before.find(c.path.substr(0, c.path.find('.')));
        return l && (l->type == LightType::Bendy || l->type == LightType::BentArea);
    });
    if (!chained) return changes;
    Rig after = before;
    if (!protocol::applyChanges(after, changes)) return changes;
    for (const Light& a : after.lights) {
        const Light* b = before.find(a.name);
        if (!b) continue;
        auto limit = limitChainEdit(*b, a);
        if (!limit) continue;
        const json limitedJson = protocol::toJson(limit->light);
        const std::string prefix = a.name + ".";
        json applied = json::array();
        for (protocol::Change& c : changes) {
            if (c.path.rfind(prefix, 0) != 0) continue;
            int index = -1;
            const protocol::Property* row = protocol::findLightProperty(c.path.substr(prefix.size()), &index);
            // Only the interpolated properties differ from what the client sent; rows the light's
            // JSON does not hold (key, unkey) stay as they are.
            if (!row) continue;
            const std::string list = *row->indexOf ? row->indexOf : row->path;
            if (!limitedJson.contains(list)) continue;
            const json& v = limitedJson[list];
            if (*row->indexOf) {
                const int at = index - row->indexBase;
                if (at >= 0 && size_t(at) < v.size()) c.value = v[size_t(at)];
            } else {
                c.value = v;
            }
        }
        // Whatever the rewritten changes still leave different (a property the edit changed
        // under another path, or one that moved only through the interpolation), in full.
        Rig check = before;
        if (!protocol::applyChanges(check, changes)) continue;
        const Light* now = check.find(a.name);
        if (!now) continue;
        for (const protocol::Property& row : protocol::lightProperties()) {
            if (!row.same || !row.get || row.readOnly || row.same(*now, limit->light)) continue;
            changes.push_back({prefix + row.path, row.get(limit->light)});
        }
        for (const protocol::Change& c : changes)
            if (c.path.rfind(prefix, 0) == 0) applied.push_back({{"path", c.path}, {"value", c.value}});
        char pct[32];
        std::snprintf(pct, sizeof pct, "%.0f %%", 100.0 * limit->fraction);
        report.push_back({{"light", a.name},
                          {"fraction", limit->fraction},
                          {"warning", limit->why},
                          {"message", a.name + ": stopped " + pct + " of the way, before the tube folds (" + limit->why + ")"},
                          {"changes", std::move(applied)}});
    }
    return changes;
}

// The scene's box and each object's, [minx, miny, minz, maxx, maxy, maxz] in world space, from
// the positions of the samples the shot covers (coverage > 0): what a schematic view can draw of
// the scene without its file. Only what the camera sees is in a shot, so a box holds an object's
// visible part; an object that no covered sample shows has null. One pass over the samples,
// once per session (the shot never changes).
void addBounds(const DeepBuffer& shot, json& description) {
    using Box = std::array<float, 6>;
    const Box empty = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    auto grow = [](Box& b, const float* p) {
        for (int k = 0; k < 3; ++k) {
            b[k] = std::min(b[k], p[k]);
            b[3 + k] = std::max(b[3 + k], p[k]);
        }
    };
    Box scene = empty;
    std::vector<Box> objects(shot.objectNames.size(), empty);
    const size_t n = shot.sampleCount();
    // A file may lack a layer (then its vector is empty): such samples count for the scene only.
    const bool hasIds = shot.objectId.size() >= n;
    if (shot.P.size() >= 3 * n && shot.A.size() >= n) {
        for (size_t s = 0; s < n; ++s) {
            if (!(shot.A[s] > 0.f)) continue;
            const float* p = &shot.P[3 * s];
            if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
            grow(scene, p);
            const uint32_t id = hasIds ? shot.objectId[s] : 0;
            if (id >= 1 && id <= objects.size()) grow(objects[id - 1], p);
        }
    }
    auto toJson = [](const Box& b) { return b[0] <= b[3] ? json(b) : json(nullptr); };
    json list = json::array();
    for (const Box& b : objects) list.push_back(toJson(b));
    description["bounds"] = toJson(scene);
    description["objectBounds"] = std::move(list);
    protocol::shortestFloats(description["bounds"]);
    protocol::shortestFloats(description["objectBounds"]);
}

} // namespace

Session::Session(std::string id, const DeepBuffer& shot, std::string shotPath, Rig rig) : mId(std::move(id)), mRig(std::move(rig)) {
    updateWarnings(mRig);
    mLimits.imagePixels = uint64_t(shot.width) * uint64_t(shot.height);
    mDescription = {{"shot", shotPath},
                    {"source", shot.sourcePath},
                    {"width", shot.width},
                    {"height", shot.height},
                    {"camera", cameraJson(shot.camera)},
                    {"objects", shot.objectNames}};
    addBounds(shot, mDescription);
}

Result<std::unique_ptr<Session>> Session::open(std::string id, const DeepBuffer& shot,
                                               std::string shotPath, Rig initialRig,
                                               const std::filesystem::path& dir,
                                               size_t snapshotEvery) {
    DFB_CHECK(snapshotEvery >= 1);
    std::unique_ptr<Session> s(new Session(std::move(id), shot, std::move(shotPath), std::move(initialRig)));
    s->mSnapshotEvery = snapshotEvery;
    if (dir.empty()) return s;
    std::vector<json> ops;
    const bool journalExisted = std::filesystem::exists(dir / Journal::JOURNAL_FILE);
    auto journal = Journal::open(dir, &ops, &s->mRecoveryReport);
    if (!journal) return journal.error();
    auto snapshot = Journal::readSnapshot(dir);
    if (!snapshot)
        return snapshot.error();
    auto savedVersion = Journal::savedRigVersion(dir);
    const std::string where = (dir / Journal::JOURNAL_FILE).string();
    const std::string snapWhere = (dir / Journal::SNAPSHOT_FILE).string();
    const std::string rigWhere = (dir / Journal::RIG_FILE).string();
    const std::string refusal =
        ": refusing to start the session afresh at version 1 (restore the journal, or remove " +
        dir.string() + " to start afresh on purpose)";
    if (ops.empty()) {
        // The base record is on disk before rig.json or a snapshot is ever written, so either
        // of them beside an empty journal means the journal was lost, not that the session is new.
        // A refusal leaves a missing journal missing, as the operator found it.
        std::error_code ignored;
        if (!journalExisted && (snapshot.value() || !savedVersion ||
                                (savedVersion.value() && *savedVersion.value() > 1))) {
            std::filesystem::remove(dir / Journal::JOURNAL_FILE, ignored);
        }
        if (snapshot.value()) {
            return makeError(ErrorCode::InvalidFile,
                             where + " is empty or missing but " + snapWhere +
                                 " holds the session at version " +
                                 protocol::dump((*snapshot.value())["v"]) + refusal);
        }
        if (!savedVersion)
            return makeError(ErrorCode::InvalidFile, where + " is empty or missing and " +
                                                         savedVersion.error().message + refusal);
        if (savedVersion.value() && *savedVersion.value() > 1) {
            return makeError(ErrorCode::InvalidFile,
                             where + " is empty or missing but " + rigWhere + " is at version " +
                                 std::to_string(*savedVersion.value()) + refusal);
        }
        if (auto st = journal->append(json{{"op", "base"}, {"rig", protocol::toJson(s->mRig)}}); !st) return st.error();
    } else {
        // Every record after the first lands on the next version; check that before replaying so
        // that a gap is named, and so that the snapshot can be placed in the journal.
        const std::string firstKind = ops[0].value("op", "");
        uint64_t start = 0;
        if (firstKind == "base") {
            auto base = protocol::rigFromJson(ops[0].contains("rig") ? ops[0]["rig"] : json());
            if (!base)
                return makeError(ErrorCode::InvalidFile,
                                 where + ":1: base rig: " + base.error().message);
            s->mRig = base.value();
            updateWarnings(s->mRig);
            start = s->mRig.version;
        } else if (firstKind == "snapshot" && ops[0].contains("v") &&
                   ops[0]["v"].is_number_unsigned()) {
            start = ops[0]["v"].get<uint64_t>();
        } else {
            return makeError(
                ErrorCode::InvalidFile,
                where + ":1: the journal starts with neither the base rig nor a snapshot record");
        }
        for (size_t i = 1; i < ops.size(); ++i) {
            const json& v = ops[i].contains("v") ? ops[i]["v"] : json();
            if (!v.is_number_unsigned() || v.get<uint64_t>() != start + i) {
                return makeError(ErrorCode::InvalidFile,
                                 where + ":" + std::to_string(i + 1) + ": the record has version " +
                                     protocol::dump(v) + ", the one before it " +
                                     std::to_string(start + i - 1) +
                                     ": the journal is not contiguous (left untouched)");
            }
        }
        const uint64_t last = start + ops.size() - 1;
        size_t from = 1;
        if (snapshot.value()) {
            // The snapshot is written before the journal is compacted: after a crash between the
            // two, the old journal still holds records up to and beyond the snapshot; skip those.
            const json& state = *snapshot.value();
            const uint64_t v = state.value("v", uint64_t(0));
            if (v < start || v > last) {
                return makeError(
                    ErrorCode::InvalidFile,
                    snapWhere + " holds version " + std::to_string(v) + " but " + where +
                        " covers versions " + std::to_string(start) + " to " +
                        std::to_string(last) +
                        ": the journal does not continue the snapshot (both left untouched)");
            }
            if (auto st = s->restoreState(state); !st)
                return makeError(ErrorCode::InvalidFile, snapWhere + ": " + st.error().message);
            from = size_t(v - start) + 1;
        } else if (firstKind == "snapshot") {
            return makeError(ErrorCode::InvalidFile,
                             where + ":1: the journal continues a snapshot at version " +
                                 std::to_string(start) + " but " + snapWhere + " is missing");
        }
        for (size_t i = from; i < ops.size(); ++i) {
            auto r = s->apply(ops[i], false);
            if (!r) {
                return makeError(ErrorCode::InvalidFile, where + ":" + std::to_string(i + 1) + ": cannot replay: " + r.error().message);
            }
        }
        // rig.json is written only after a change is in the journal, so a newer one means the
        // journal lost acknowledged changes; one newer after a repair: the moved-aside record was
        // one.
        if (savedVersion && savedVersion.value() && *savedVersion.value() > s->mRig.version) {
            const std::string lost = rigWhere + " is at version " +
                                     std::to_string(*savedVersion.value()) + " but " + where +
                                     " ends at version " + std::to_string(s->mRig.version);
            if (s->mRecoveryReport.empty() || *savedVersion.value() > s->mRig.version + 1) {
                return makeError(
                    ErrorCode::InvalidFile,
                    lost + ": acknowledged changes are missing from the journal" +
                        (s->mRecoveryReport.empty() ? "" : " (" + s->mRecoveryReport + ")"));
            }
            s->mRecoveryReport +=
                "; " + lost + ": the moved-aside record was an acknowledged change, now undone";
        }
    }
    s->mMergeableBy = 0; // client ids start again after a restart: no merging across it
    s->mJournal = std::move(journal.value());
    if (auto st = s->mJournal->saveRig(protocol::toJson(s->mRig)); !st) return st.error();
    return s;
}

json Session::stateJson() const {
    auto steps = [](const auto& list) {
        json arr = json::array();
        for (const Step& st : list)
            arr.push_back({protocol::toJson(st.before), protocol::toJson(st.after)});
        return arr;
    };
    json log = json::array();
    for (const json& rec : mLog)
        log.push_back(rec);
    // mergeableBy: a merged edit journaled after the snapshot must merge on replay as it did live.
    return json{{"op", "state"},
                {"v", mRig.version},
                {"rig", protocol::toJson(mRig)},
                {"undo", steps(mUndo)},
                {"redo", steps(mRedo)},
                {"log", std::move(log)},
                {"mergeableBy", mMergeableBy}};
}

Status Session::restoreState(const json& state) {
    auto rig = [](const json& j) -> Result<Rig> {
        auto r = protocol::rigFromJson(j);
        if (!r)
            return r.error();
        updateWarnings(r.value()); // the server's, recomputed as when the rig was made
        return r;
    };
    auto steps = [&](const char* key, auto& out) -> Status {
        if (!state.contains(key) || !state[key].is_array())
            return makeError(ErrorCode::InvalidFile, std::string(key) + ": expected an array");
        for (const json& st : state[key]) {
            if (!st.is_array() || st.size() != 2)
                return makeError(ErrorCode::InvalidFile,
                                 std::string(key) + ": expected [before, after] pairs");
            auto before = rig(st[0]), after = rig(st[1]);
            if (!before)
                return before.error();
            if (!after)
                return after.error();
            out.push_back({std::move(before.value()), std::move(after.value())});
        }
        return okStatus();
    };
    auto r = rig(state.contains("rig") ? state["rig"] : json());
    if (!r)
        return r.error();
    if (r->version != state.value("v", uint64_t(0)))
        return makeError(ErrorCode::InvalidFile, "the rig's version is not the snapshot's");
    mUndo.clear();
    mRedo.clear();
    mLog.clear();
    if (auto st = steps("undo", mUndo); !st)
        return st;
    if (auto st = steps("redo", mRedo); !st)
        return st;
    if (!state.contains("log") || !state["log"].is_array())
        return makeError(ErrorCode::InvalidFile, "log: expected an array");
    for (const json& rec : state["log"]) {
        if (!rec.is_object() || !rec.contains("version") || !rec["version"].is_number_unsigned()) {
            return makeError(ErrorCode::InvalidFile, "log: expected change records with a version");
        }
        mLog.push_back(rec);
    }
    mMergeableBy = state.value("mergeableBy", uint64_t(0));
    mRig = std::move(r.value());
    return okStatus();
}

void Session::snapshotIfDue() {
    // records() counts the first record (base or snapshot) too.
    if (!mJournal || mJournal->records() <= mSnapshotEvery)
        return;
    Status st = mJournal->writeSnapshot(stateJson());
    // Only once the snapshot is durable may the journal forget what it replaces.
    if (st)
        st = mJournal->compact({json{{"op", "snapshot"}, {"v", mRig.version}}});
    if (!st) {
        std::fprintf(
            stderr, "dfb-server: session %s: snapshot: %s (the journal still holds every change)\n",
            mId.c_str(), st.error().toString().c_str());
    }
}

void Session::updateFits(Rig& rig) const {
    for (Light& l : rig.lights) {
        // Only one-shot uses (alpha, beta): a light shading with LTC (a uniform one, by default)
        // costs no fit, so resizing a soft box does not stall the session's thread on refits.
        if (l.type != LightType::Area || shadesWithLtc(l)) continue;
        auto ab = fitAreaAlphaBeta(l, mAssetDir);
        l.alphaBeta = ab ? ab.value() : Light{}.alphaBeta;
    }
}

Status Session::checkImages(const Rig& next) const {
    // Cookies and area lights' patterns name images in the asset folder; a new name must be one.
    for (const auto& [field, prop] : {std::pair{&Light::cookie, "cookie"}, std::pair{&Light::pattern, "pattern"}}) {
        for (const Light& l : next.lights) {
            const std::string& name = l.*field;
            const Light* before = mRig.find(l.name);
            if (name.empty() || (before && before->*field == name)) continue;
            if (auto img = checkImageFile((std::filesystem::path(mAssetDir) / name).string()); !img) {
                // The network layer takes the server's folders out of what clients see
                // (SharedState::redact), so the asset folder is not named here.
                return makeError(ErrorCode::InvalidValue, l.name + "." + prop + ": '" + name +
                                                              "' is not a readable image in the asset folder (" + img.error().message + ")");
            }
        }
    }
    // An environment light's map: float data within the size limit (header only).
    for (const Light& l : next.lights) {
        const Light* before = mRig.find(l.name);
        if (l.envMap.empty() || (before && before->envMap == l.envMap)) continue;
        if (auto img = checkHdrImageFile((std::filesystem::path(mAssetDir) / l.envMap).string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
            !img) {
            return makeError(ErrorCode::InvalidValue, l.name + ".map: '" + l.envMap + "' is not an environment map in the asset folder (" +
                                                          img.error().message + ")");
        }
    }
    return okStatus();
}

Result<ChangeOutcome> Session::apply(const json& op, bool record) {
    const std::string kind = op.value("op", "");
    Rig next = mRig;
    next.version = mRig.version + 1;
    ChangeOutcome out;
    out.info.kind = kind;
    out.info.rigVersion = next.version;
    out.info.byClient = op.value("by", uint64_t(0));
    out.info.byName = op.value("byName", "");
    enum { None, PushUndo, Undo, Redo } history = None;
    if (kind == "edit") {
        out.info.changes = changesFromJson(op.contains("changes") ? op["changes"] : json());
        if (out.info.changes.empty()) return makeError(ErrorCode::Protocol, "edit without changes");
        if (auto st = protocol::applyChanges(next, out.info.changes); !st) return st.error();
        next.version = mRig.version + 1; // applyChanges keeps the version; make sure
        updateWarnings(next);
        updateFits(next);
        history = PushUndo;
    } else if (kind == "time") {
        if (!op.contains("t") || !op["t"].is_number()) return makeError(ErrorCode::Protocol, "time without t");
        next.time = op["t"].get<double>();
        out.info.changes = {{"time", op["t"]}};
    } else if (kind == "undo" || kind == "redo") {
        if (kind == "undo" && mUndo.empty()) return makeError(ErrorCode::MissingData, "nothing to undo");
        if (kind == "redo" && mRedo.empty()) return makeError(ErrorCode::MissingData, "nothing to redo");
        const Step& s = kind == "undo" ? mUndo.back() : mRedo.back();
        next = kind == "undo" ? s.before : s.after;
        next.time = mRig.time; // the clock is not part of the history
        next.version = mRig.version + 1;
        history = kind == "undo" ? Undo : Redo;
    } else if (kind == "replace") {
        auto r = protocol::rigFromJson(op.contains("rig") ? op["rig"] : json());
        if (!r) return r.error();
        next = r.value();
        next.version = mRig.version + 1;
        updateWarnings(next);
        updateFits(next);
        history = PushUndo;
    } else {
        return makeError(ErrorCode::Protocol, "unknown journal operation '" + kind + "'");
    }
    if (kind == "undo" || kind == "redo" || kind == "replace") out.info.rig = next;

    // Only for new changes: a replayed journal shows what was accepted then, even if a cookie
    // file has gone since (the render then reports it).
    if (record && (kind == "edit" || kind == "replace")) {
        if (auto st = checkImages(next); !st) return st.error();
    }
    if (record && mClosed) {
        return makeError(ErrorCode::Moved, "session '" + mId + "' was closed on this node (it moves to another, or reopens): retry");
    }
    if (record) {
        json line = op;
        line["v"] = next.version;
        if (mJournal) {
            // On disk before it is applied and acknowledged; on failure nothing changes.
            if (auto st = mJournal->append(line); !st) return st.error();
        }
    } else if (!op.contains("v") || !op["v"].is_number_unsigned() || op["v"].get<uint64_t>() != next.version) {
        return makeError(ErrorCode::InvalidFile, "operation records version " + protocol::excerpt(op.value("v", json())) + ", replay reached " +
                                                     std::to_string(next.version));
    }

    // A merged edit continues its author's newest undo step (one drag, one undo). Anything else
    // that changes the rig (an edit by someone else, undo, redo, replace) closes that step.
    const bool merged = history == PushUndo && kind == "edit" && op.value("merge", false) && out.info.byClient != 0 &&
                        out.info.byClient == mMergeableBy && !mUndo.empty();
    switch (history) {
    case PushUndo:
        if (merged) {
            mUndo.back().after = next;
        } else {
            mUndo.push_back({mRig, next});
            if (mUndo.size() > MAX_UNDO) mUndo.pop_front();
        }
        mRedo.clear();
        break;
    case Undo:
        mRedo.push_back(mUndo.back());
        mUndo.pop_back();
        break;
    case Redo:
        mUndo.push_back(mRedo.back());
        mRedo.pop_back();
        break;
    case None: break;
    }
    if (history != None) mMergeableBy = kind == "edit" ? out.info.byClient : 0;

    json rec{{"version", next.version}, {"kind", kind}, {"by", out.info.byClient}, {"byName", out.info.byName}};
    if (out.info.rig) rec["rig"] = protocol::toJson(*out.info.rig);
    else rec["changes"] = protocol::changesToJson(out.info.changes);
    // Whole rigs now and then, so that any version in the log can be rebuilt by replaying at
    // most LOG_CHECKPOINT_EVERY records of changes (rigAtVersion, "go to this version"); the
    // first record also keeps the rig before it.
    if (mLog.empty()) rec["rigBefore"] = protocol::toJson(mRig);
    if (!out.info.rig && next.version % LOG_CHECKPOINT_EVERY == 0) rec["rigAt"] = protocol::toJson(next);
    mRig = std::move(next);
    mLog.push_back(std::move(rec));
    if (mLog.size() > MAX_LOG) {
        // The new oldest record must hold its whole rig, or the versions up to the next
        // checkpoint could no longer be rebuilt.
        json& second = mLog[1];
        if (!second.contains("rig") && !second.contains("rigAt")) {
            if (auto r = rigAtVersionLocked(second["version"].get<uint64_t>())) second["rigAt"] = protocol::toJson(r.value());
        }
        mLog.pop_front();
    }
    if (record && mJournal) {
        mRigSaveDue = true;
        if (std::chrono::steady_clock::now() - mLastRigSave >= RIG_SAVE_INTERVAL) saveRigNow();
        snapshotIfDue();
    }
    return out;
}

void Session::saveRigNow() {
    mRigSaveDue = false;
    mLastRigSave = std::chrono::steady_clock::now();
    if (auto st = mJournal->saveRig(protocol::toJson(mRig)); !st) {
        std::fprintf(stderr, "dfb-server: session %s: %s (the journal holds the change)\n", mId.c_str(), st.error().toString().c_str());
    }
}

Session::~Session() { flushSavedRig(); }

void Session::close() {
    std::lock_guard lock(mMutex);
    if (mJournal && mRigSaveDue) saveRigNow();
    mClosed = true;
}

bool Session::closed() const {
    std::lock_guard lock(mMutex);
    return mClosed;
}

void Session::flushSavedRig() {
    std::lock_guard lock(mMutex);
    if (mJournal && mRigSaveDue) saveRigNow();
}

Result<ChangeOutcome> Session::edit(const std::vector<protocol::Change>& changes, const Author& by, std::optional<uint64_t> base,
                                    std::optional<uint64_t> ifVersion, bool merge, bool allowFold) {
    std::lock_guard lock(mMutex);
    if (ifVersion && *ifVersion != mRig.version) {
        return makeError(ErrorCode::Conflict, "the rig is at version " + std::to_string(mRig.version) + ", not " +
                                                  std::to_string(*ifVersion) + "; nothing was changed");
    }
    if (changes.empty()) return makeError(ErrorCode::Protocol, "an edit needs at least one change");
    json limited = json::array();
    // Validate on a copy first so that a refused edit is never journaled.
    {
        Rig probe = mRig;
        if (auto st = protocol::applyChanges(probe, changes); !st) return st.error();
    }
    // A drag that would fold a tube stops where it is still sound (issue: artists drag a point a
    // little and the tube folded, cutting hard lines through the image). The journal records the
    // limited changes, so a replay needs no limiter.
    const std::vector<protocol::Change> applied = allowFold ? changes : limitFolds(mRig, changes, limited);
    {
        Rig probe = mRig;
        if (auto st = protocol::applyChanges(probe, applied); !st) return st.error();
        if (auto st = protocol::checkRigLimits(probe, mLimits); !st) return st.error();
        if (auto st = checkImages(probe); !st) return st.error();
    }
    json overwrote = json::array();
    if (base && *base < mRig.version) {
        for (const json& rec : mLog) {
            if (rec["version"].get<uint64_t>() <= *base) continue;
            for (const auto& c : applied) {
                bool hit = rec.contains("rig");
                if (!hit) {
                    for (const json& o : rec["changes"]) hit = hit || overlaps(c.path, o["path"].get<std::string>());
                }
                if (hit) overwrote.push_back({{"path", c.path}, {"version", rec["version"]}, {"by", rec["by"]}, {"kind", rec["kind"]}});
            }
        }
    }
    json op{{"op", "edit"}, {"by", by.clientId}, {"byName", by.name}, {"changes", protocol::changesToJson(applied)}};
    if (merge) op["merge"] = true; // journaled, so that a replay rebuilds the same history
    auto r = apply(op, true);
    if (r) {
        r->overwrote = std::move(overwrote);
        r->limited = std::move(limited);
    }
    return r;
}

Result<ChangeOutcome> Session::setTime(double seconds, const Author& by) {
    std::lock_guard lock(mMutex);
    return apply(json{{"op", "time"}, {"by", by.clientId}, {"byName", by.name}, {"t", seconds}}, true);
}

Result<ChangeOutcome> Session::undo(const Author& by) {
    std::lock_guard lock(mMutex);
    return apply(json{{"op", "undo"}, {"by", by.clientId}, {"byName", by.name}}, true);
}

Result<ChangeOutcome> Session::redo(const Author& by) {
    std::lock_guard lock(mMutex);
    return apply(json{{"op", "redo"}, {"by", by.clientId}, {"byName", by.name}}, true);
}

Result<ChangeOutcome> Session::replace(const Rig& rig, const Author& by, std::optional<uint64_t> ifVersion) {
    std::lock_guard lock(mMutex);
    if (ifVersion && *ifVersion != mRig.version) {
        return makeError(ErrorCode::Conflict, "the rig is at version " + std::to_string(mRig.version) + ", not " +
                                                  std::to_string(*ifVersion) + "; nothing was changed");
    }
    if (auto st = protocol::checkRigLimits(rig, mLimits); !st) return st.error();
    json r = protocol::toJson(rig);
    r.erase("version");
    for (json& l : r["lights"]) l.erase("warning"), l.erase("alphaBeta"); // the server's, recomputed
    return apply(json{{"op", "replace"}, {"by", by.clientId}, {"byName", by.name}, {"rig", r}}, true);
}

Rig Session::rig() const {
    std::lock_guard lock(mMutex);
    return mRig;
}

uint64_t Session::rigVersion() const {
    std::lock_guard lock(mMutex);
    return mRig.version;
}

size_t Session::undoDepth() const {
    std::lock_guard lock(mMutex);
    return mUndo.size();
}

size_t Session::redoDepth() const {
    std::lock_guard lock(mMutex);
    return mRedo.size();
}

json Session::history(uint64_t since) const {
    std::lock_guard lock(mMutex);
    json arr = json::array();
    for (const json& rec : mLog) {
        if (rec["version"].get<uint64_t>() <= since) continue;
        json r = rec;
        r.erase("rigAt"); // the server's checkpoints, not part of the entry
        r.erase("rigBefore");
        arr.push_back(std::move(r));
    }
    return arr;
}

Result<Rig> Session::rigAtVersion(uint64_t version) const {
    std::lock_guard lock(mMutex);
    return rigAtVersionLocked(version);
}

Result<Rig> Session::rigAtVersionLocked(uint64_t version) const {
    if (version == mRig.version) return mRig;
    auto parse = [](const json& j, uint64_t v) -> Result<Rig> {
        auto r = protocol::rigFromJson(j);
        if (!r) return r.error();
        r->version = v;
        return r;
    };
    std::optional<Rig> cur;
    for (const json& rec : mLog) {
        const uint64_t v = rec["version"].get<uint64_t>();
        if (!cur && rec.contains("rigBefore")) {
            auto r = parse(rec["rigBefore"], v - 1);
            if (!r) return r.error();
            if (v - 1 == version) return r;
            cur = std::move(r.value());
        }
        if (v > version) break;
        if (rec.contains("rigAt") || rec.contains("rig")) {
            auto r = parse(rec.contains("rigAt") ? rec["rigAt"] : rec["rig"], v);
            if (!r) return r.error();
            cur = std::move(r.value());
        } else if (cur) {
            if (auto st = protocol::applyChanges(*cur, changesFromJson(rec["changes"])); !st) return st.error();
            cur->version = v;
        }
        if (v == version && cur) return *cur;
    }
    const uint64_t oldest = mLog.empty() ? mRig.version : mLog.front()["version"].get<uint64_t>() - (mLog.front().contains("rigBefore") ? 1 : 0);
    return makeError(ErrorCode::MissingData, "version " + std::to_string(version) + " is not in the session's history (it goes back to version " +
                                                 std::to_string(oldest) + " and up to " + std::to_string(mRig.version) + ")");
}

} // namespace dfb
