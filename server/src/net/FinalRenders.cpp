#include "net/FinalRenders.h"

#include <dfb/server/ImageCodec.h>
#include <dfb/server/Outputs.h>

#include <boost/process.hpp>
#include <boost/process/extend.hpp>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sys/prctl.h>

namespace dfb::net {

namespace bp = boost::process;
namespace fs = std::filesystem;

namespace {

const char* toString(FinalRenders::State s) {
    switch (s) {
    case FinalRenders::State::None: return "none";
    case FinalRenders::State::Exporting: return "exporting";
    case FinalRenders::State::Running: return "running";
    case FinalRenders::State::Done: return "done";
    case FinalRenders::State::Failed: return "failed";
    case FinalRenders::State::Cancelled: return "cancelled";
    }
    return "none";
}

// The child's output kept for an error message: its last lines, at most this many bytes.
constexpr size_t MAX_KEPT_OUTPUT = 2048;
// A line longer than this is cut (Blender's lines are ~150 bytes).
constexpr size_t MAX_LINE = 64 * 1024;
// Notes kept per render (one per light at most; a rig has at most a few hundred).
constexpr size_t MAX_NOTES = 256;

} // namespace

struct FinalRenders::Child {
    explicit Child(asio::io_context& ioc) : pipe(ioc), timer(ioc) {}
    bp::async_pipe pipe;
    bp::child process;
    asio::steady_timer timer;
    std::string buffer;
};

FinalRenders::FinalRenders(asio::io_context& ioc, const DeepBuffer& shot, Exporter exporter, Notify notify)
    : mIoc(ioc), mShot(shot), mExporter(std::move(exporter)), mNotify(std::move(notify)) {}

FinalRenders::~FinalRenders() {
    if (mChild && mChild->process.valid() && mChild->process.running()) mChild->process.terminate();
    if (!mFolder.empty()) {
        std::error_code ec;
        fs::remove_all(mFolder, ec);
    }
}

nlohmann::json FinalRenders::status() const {
    nlohmann::json j{{"type", "final"}, {"state", toString(mState)}};
    if (mState == State::None) return j;
    j["rigVersion"] = mRig.version;
    j["samples"] = {mSamplesDone, mSamplesTotal};
    j["percent"] = mSamplesTotal > 0 ? 100.0 * mSamplesDone / mSamplesTotal : 0.0;
    j["directOnly"] = mOptions.directOnly;
    j["notes"] = mNotes;
    j["seconds"] = mState == State::Exporting || mState == State::Running
                       ? std::chrono::duration<double>(std::chrono::steady_clock::now() - mStarted).count()
                       : mSeconds;
    if (!mError.empty()) j["error"] = mError;
    return j;
}

Result<nlohmann::json> FinalRenders::start(const Rig& rig, const FinalRenderOptions& options, const std::string& assetDirectory) {
    if (options.samples < 1 || options.samples > mLimits.maxSamples) {
        return makeError(ErrorCode::InvalidValue, "final render: samples must be 1.." + std::to_string(mLimits.maxSamples) + ", not " +
                                                      std::to_string(options.samples) + " (the server's limit)");
    }
    const bool busy = mState == State::Exporting || mState == State::Running;
    const bool same = mRig.version == rig.version && mOptions.samples == options.samples && mOptions.directOnly == options.directOnly;
    if ((busy || mState == State::Done) && same) return status(); // joined, or already there
    if (busy) {
        return makeError(ErrorCode::Conflict, "a final render of rig version " + std::to_string(mRig.version) +
                                                  " is running; cancel it first (DELETE .../final) or wait for it");
    }
    if (rig.lights.empty()) return makeError(ErrorCode::MissingData, "final render: the rig has no lights, so the render would be black");
    ++mGeneration;
    mState = State::Exporting;
    mRig = rig;
    mOptions = options;
    mAssetDirectory = assetDirectory;
    mSamplesDone = 0;
    mSamplesTotal = options.samples;
    mNotes.clear();
    mError.clear();
    mLastLines.clear();
    mImage.reset();
    mExr.reset();
    mPng.reset();
    mStarted = std::chrono::steady_clock::now();
    const uint64_t generation = mGeneration;
    mExporter(rig, [this, generation](Result<std::string> glb) {
        asio::post(mIoc, [this, generation, glb = std::move(glb)]() mutable {
            if (generation != mGeneration || mState != State::Exporting) return; // cancelled meanwhile
            if (!glb) return finish(State::Failed, "cannot export the scene: " + glb.error().message);
            spawn(glb.value());
        });
    });
    mNotify(status());
    return status();
}

void FinalRenders::spawn(const std::string& glb) {
    if (!mFolder.empty()) {
        std::error_code ec;
        fs::remove_all(mFolder, ec);
        mFolder.clear();
    }
    std::string pattern = (fs::temp_directory_path() / "dfb-final-XXXXXX").string();
    if (!mkdtemp(pattern.data())) return finish(State::Failed, "cannot make a folder for the render in the temporary directory");
    mFolder = pattern;
    const std::string scene = mFolder + "/scene.glb", job = mFolder + "/job.json", output = mFolder + "/final.exr";
    {
        std::ofstream g(scene, std::ios::binary);
        g.write(glb.data(), std::streamsize(glb.size()));
        std::ofstream j(job);
        j << finalRenderJob(mShot, mRig, scene, output, mAssetDirectory, mOptions).dump();
        if (!g || !j) return finish(State::Failed, "cannot write the render's job to the temporary directory");
    }
    const auto exe = mLimits.blender.find('/') == std::string::npos ? bp::search_path(mLimits.blender) : boost::filesystem::path(mLimits.blender);
    if (exe.empty()) return finish(State::Failed, "Blender ('" + mLimits.blender + "') is not installed: scripts/setup installs it");
    mChild = std::make_unique<Child>(mIoc);
    const uint64_t generation = mGeneration;
    std::error_code ec;
    mChild->process = bp::child(
        exe, bp::args({"-b", "--factory-startup", "--python", blenderScriptDirectory() + "/dfb_final.py", "--", job}),
        bp::std_out > mChild->pipe, bp::std_err > bp::null, bp::std_in < bp::null, ec,
        // The render dies with the server, however the server ends.
        bp::extend::on_exec_setup = [](auto&) { ::prctl(PR_SET_PDEATHSIG, SIGKILL); });
    if (ec) {
        mChild.reset();
        return finish(State::Failed, "cannot start Blender: " + ec.message());
    }
    mState = State::Running;
    mChild->timer.expires_after(mLimits.timeLimit);
    mChild->timer.async_wait([this, generation](const boost::system::error_code& e) {
        if (e || generation != mGeneration || mState != State::Running) return;
        finish(State::Failed, "the render took longer than the server's limit of " + std::to_string(mLimits.timeLimit.count()) +
                                  " s (--final-timeout) and was stopped");
    });
    mNotify(status());
    readLine();
}

void FinalRenders::readLine() {
    const uint64_t generation = mGeneration;
    asio::async_read_until(mChild->pipe, asio::dynamic_buffer(mChild->buffer, MAX_LINE), '\n',
                           [this, generation](const boost::system::error_code& ec, size_t n) {
                               if (generation != mGeneration || mState != State::Running || !mChild) return;
                               if (ec) {
                                   // The child closed its output: it has exited or is exiting.
                                   mChild->process.wait();
                                   const int code = mChild->process.exit_code();
                                   if (code != 0) {
                                       const size_t e = mLastLines.rfind("DFB_ERROR ");
                                       return finish(State::Failed, e != std::string::npos
                                                                        ? "Blender: " + mLastLines.substr(e + 10, mLastLines.find('\n', e) - e - 10)
                                                                        : "Blender exited with status " + std::to_string(code) + ": " + mLastLines);
                                   }
                                   auto img = readLinearImage(mFolder + "/final.exr");
                                   if (!img) return finish(State::Failed, "Blender wrote no readable image: " + img.error().message);
                                   const float exposure = std::exp2(mRig.exposureStops);
                                   for (size_t i = 0; i < img->rgba.size(); i += 4) {
                                       for (size_t c = 0; c < 3; ++c) img->rgba[i + c] *= exposure;
                                   }
                                   mImage = std::make_shared<const ImageF>(std::move(img.value()));
                                   return finish(State::Done, "");
                               }
                               std::string line = mChild->buffer.substr(0, n > 0 ? n - 1 : 0);
                               mChild->buffer.erase(0, n);
                               mLastLines += line + "\n";
                               if (mLastLines.size() > MAX_KEPT_OUTPUT) mLastLines.erase(0, mLastLines.size() - MAX_KEPT_OUTPUT);
                               static const std::regex sample(R"(\| Sample (\d+)/(\d+))");
                               std::smatch m;
                               if (line.rfind("DFB_NOTE ", 0) == 0) {
                                   if (mNotes.size() < MAX_NOTES) mNotes.push_back(line.substr(9));
                               } else if (std::regex_search(line, m, sample)) {
                                   const int done = std::stoi(m[1].str().substr(0, 9)), total = std::stoi(m[2].str().substr(0, 9));
                                   if (total > 0 && done != mSamplesDone) {
                                       mSamplesDone = std::min(done, total);
                                       mSamplesTotal = total;
                                       mNotify(status());
                                   }
                               }
                               readLine();
                           });
}

Result<std::shared_ptr<const std::string>> FinalRenders::encoded(bool exr, float extraStops, std::optional<ViewTransform> viewTransform) {
    if (mState != State::Done || !mImage) return std::shared_ptr<const std::string>();
    if (!exr && (extraStops != 0.f || (viewTransform && *viewTransform != mRig.viewTransform))) {
        ImageF view = *mImage;
        const float scale = std::exp2(extraStops);
        for (size_t i = 0; i < view.rgba.size(); i += 4) {
            for (size_t c = 0; c < 3; ++c) view.rgba[i + c] *= scale;
        }
        auto bytes = encodePng(displayImage(view, viewTransform.value_or(mRig.viewTransform)));
        if (!bytes) return bytes.error();
        return std::make_shared<const std::string>(bytes->begin(), bytes->end());
    }
    std::shared_ptr<const std::string>& cached = exr ? mExr : mPng;
    if (!cached) {
        auto bytes = exr ? encodeExr({{"", *mImage}}) : encodePng(displayImage(*mImage, mRig.viewTransform));
        if (!bytes) return bytes.error();
        cached = std::make_shared<const std::string>(bytes->begin(), bytes->end());
    }
    return cached;
}

Result<nlohmann::json> FinalRenders::cancel() {
    if (mState != State::Exporting && mState != State::Running) {
        return makeError(ErrorCode::MissingData, "no final render is running");
    }
    finish(State::Cancelled, "");
    return status();
}

void FinalRenders::finish(State state, const std::string& error) {
    if (mChild) {
        mChild->timer.cancel();
        if (mChild->process.valid() && mChild->process.running()) mChild->process.terminate(); // SIGKILL, then reaped
        boost::system::error_code ec;
        mChild->pipe.close(ec);
        // Closed after the handlers that still hold `this` have run (they see the new state).
        asio::post(mIoc, [child = std::shared_ptr<Child>(std::move(mChild))] {});
    }
    ++mGeneration;
    mState = state;
    mError = error;
    mSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStarted).count();
    if (!mFolder.empty()) {
        std::error_code ec;
        fs::remove_all(mFolder, ec);
        mFolder.clear();
    }
    mNotify(status());
}

} // namespace dfb::net
