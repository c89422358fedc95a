#pragma once
// Protocol v1 messages (docs/protocol.md): the JSON text messages of the WebSocket, their
// validation and their encoding, shared by the server and every client. Decoders never throw:
// anything malformed gives an Error whose message names the message type and the field.

#include <dfb/core/Result.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace dfb::protocol {

/// The protocol version this codec speaks; `hello.protocol` and `welcome.protocol` carry it.
constexpr int PROTOCOL_VERSION = 1;

/// Largest text message a peer may send (bytes): edits are small; the server closes the
/// connection on anything larger.
constexpr size_t MAX_TEXT_MESSAGE_BYTES = 1 << 20;

/// JSON text that never throws: bytes that are not UTF-8 (a file name, a URL) become U+FFFD.
/// Everything the server and clients send goes through it.
std::string dump(const nlohmann::json& j, int indent = -1);

/// Decodes one value of a URL query string: %XX escapes, and '+' as a space (HTML form
/// encoding); a '%' not followed by two hex digits stays as it is.
std::string percentDecode(std::string_view s);

/// What a token allows: an editor may change the rig; a viewer receives frames and changes only.
enum class Role { Editor, Viewer };
const char* toString(Role role);

// ---- view settings ------------------------------------------------------------------------------

/// How one client wants its frames: which image, how it is tone-mapped and encoded. Per client
/// (not part of the rig, not journaled); the HTTP frame endpoint takes the same settings as query
/// parameters.
struct ViewSettings {
    /// "beauty", "light:NAME" (one light alone), "reference:NAME" (an area light alone by the
    /// stratified reference, Engine::renderAreaReference), "shadow:NAME" (its visibility mask as
    /// grey) or "layer:NAME" (a G-buffer layer, where the engine provides it).
    std::string output = "beauty";
    Encoding encoding = Encoding::Jpeg;
    int quality = 85;               ///< JPEG quality, 1..100 (ignored by PNG and EXR)
    float exposureStops = 0.f;      ///< added to the rig's exposure, stops, [-20, 20]
    /// "rig" (the rig's view transform), "srgb" or "filmic": overrides the rig's for this client.
    std::string viewTransform = "rig";
    /// Shows the rig's environment lights behind the scene where the G-buffer is empty (the
    /// uncovered share of each pixel; 8-bit beauty only: light:, shadow: and layer: outputs and
    /// the EXR beauty, whose alpha is the coverage for compositing, are unchanged).
    bool background = false;

    /// True when the image is the rig's own beauty (any encoding but EXR shares the engine's
    /// 8-bit frame, the fast path every client starts on).
    bool isDefaultImage() const { return output == "beauty" && exposureStops == 0.f && viewTransform == "rig" && !background; }
    /// A string that is equal for equal settings (frames are encoded once per key and version).
    std::string key() const;
    bool operator==(const ViewSettings&) const = default;
};

nlohmann::json toJson(const ViewSettings& view);
/// Applies the fields present in `j` ({"output", "encoding", "quality", "exposure",
/// "viewTransform"}) to `base`; absent fields keep their value. InvalidValue names the field
/// (a G-buffer layer as EXR included: layers are 8-bit views).
Result<ViewSettings> applyViewJson(ViewSettings base, const nlohmann::json& j);
/// The same from an HTTP query string: output=..&format=png|jpeg|exr&quality=..&exposure=..&
/// viewTransform=.. (percent-encoded values are decoded).
Result<ViewSettings> viewFromQuery(std::string_view query);
const char* encodingName(Encoding e);
/// The MIME type of an encoding ("image/jpeg", "image/png", "image/x-exr").
const char* mimeType(Encoding e);

// ---- client -> server ---------------------------------------------------------------------------
/// Longest client name kept (bytes); a longer one is cut at a character boundary.
constexpr size_t MAX_CLIENT_NAME_BYTES = 64;
/// A client's name as the server keeps it (hello.name, the X-Dfb-Name header of HTTP edits):
/// control characters dropped, cut to MAX_CLIENT_NAME_BYTES without splitting a UTF-8 character.
std::string clientName(std::string name);

/// Optional first message: the client's display name and protocol version.
struct HelloMessage {
    int protocol = PROTOCOL_VERSION;
    std::string name; ///< shown to other clients in presence; at most 64 bytes
};
/// Change rig properties, all or none.
struct EditMessage {
    uint64_t seq = 0;                 ///< the client's own counter, echoed in ack/error
    std::vector<Change> changes;      ///< at least one
    std::optional<uint64_t> base;     ///< the rig version the client edited from (conflict report)
    std::optional<uint64_t> ifVersion; ///< apply only if the rig is still at this version
    /// Continues this client's previous edit (the next step of one drag): when the session's
    /// newest undo step is that edit's and nothing else changed the rig since, the two become one
    /// undo step. Otherwise an ordinary edit.
    bool merge = false;
    /// A BendyLight or bent area light whose chain was sound and would fold or run into itself
    /// after this edit is limited to the last sound configuration on the way (the ack says so in
    /// `limited`) unless this is true: then the edit is applied as given and the light carries
    /// a warning (docs/protocol.md "Edits that would fold a tube").
    bool allowFold = false;
};
/// Undo or redo the session's most recent edit (by anyone): the history is per session.
struct UndoMessage {
    uint64_t seq = 0;
};
struct RedoMessage {
    uint64_t seq = 0;
};
/// "Go to this version": the rig as it was at `version` (one in the session's history) replaces
/// the live one, as one undoable edit (as POST .../history/V/restore).
struct RestoreMessage {
    uint64_t seq = 0;
    uint64_t version = 0;
};
/// Set the session clock (where keyframes are evaluated), seconds.
struct TimeMessage {
    uint64_t seq = 0;
    double seconds = 0.0;
};
/// Change this client's view settings; `settings` holds only the fields to change (validated).
struct ViewMessage {
    uint64_t seq = 0;
    nlohmann::json settings;
};
/// What is at a pixel of the shot: position, normal, object, lights reaching it.
struct PickMessage {
    uint64_t seq = 0;
    int x = 0; ///< pixel column, 0 = left
    int y = 0; ///< pixel row, 0 = top
};
/// One step of an indirect-editing drag (docs/protocol.md "Drags"): `begin` grabs what pixel
/// (x, y) shows for `mode` on `light` (optionally only the BendyLight control points `points`,
/// 1..2K); each `update` moves the pointer to (x, y) and becomes an edit of the light (solved from
/// the light as it was at `begin`; the whole drag is one undo step); `end` keeps the result,
/// `cancel` puts the light back as it was at `begin`. A client has at most one drag; a `begin`
/// ends the one before.
enum class DragPhase { Begin, Update, End, Cancel };
struct DragMessage {
    uint64_t seq = 0;
    DragPhase phase = DragPhase::Begin;
    std::string mode;        ///< begin only: a name of dragModes() (checked when parsed)
    std::string light;       ///< begin only
    int x = 0, y = 0;        ///< begin and update: pixel column and row, 0 = top left
    std::vector<int> points; ///< begin only: selected control points (empty: the whole light)
};
/// Most control points a drag may select: a chain's 2K.
constexpr size_t MAX_DRAG_POINTS = 2 * MAX_BENDY_SEGMENTS;
const char* toString(DragPhase phase);

/// What this client is manipulating now (e.g. "key" or "key.position"), or nothing.
struct PresenceMessage {
    std::optional<std::string> editing;
};
/// A new annotation on the frame (docs/protocol.md "Annotations"): a pin (one point and a
/// comment) or a freehand stroke (MIN..MAX_ANNOTATION_POINTS points, an optional note), in shot
/// pixels (x right, y down from the top left corner). Viewers may send it: annotating is not
/// editing the rig. The server checks the points against the shot's size and answers an ack with
/// the new annotation.
struct AnnotateMessage {
    uint64_t seq = 0;
    std::string kind;                         ///< "pin" or "stroke"
    std::vector<std::array<double, 2>> points; ///< pin: one; stroke: 2..MAX_ANNOTATION_POINTS
    std::string text;                         ///< pin: 1..MAX_ANNOTATION_TEXT characters; stroke: optional
    std::string color;                        ///< "#rrggbb", or empty: the page's default
};
constexpr size_t MAX_ANNOTATION_POINTS = 2000;
constexpr size_t MAX_ANNOTATION_TEXT = 2000; ///< characters (Unicode code points), not bytes
/// The annotation fields of `j` (kind, points, text, color; with `message` also type and seq,
/// which the caller reads): the checks that need no shot, each error naming `what`.FIELD and its
/// limit. The same for the WebSocket message and the HTTP body (POST annotations).
Result<AnnotateMessage> annotationFromJson(const nlohmann::json& j, const std::string& what, bool message = false);

using ClientMessage = std::variant<HelloMessage, EditMessage, UndoMessage, RedoMessage, TimeMessage, ViewMessage,
                                   PickMessage, PresenceMessage, DragMessage, AnnotateMessage, RestoreMessage>;

/// Parses and validates one text message from a client (types and fields; rig values are checked
/// when applied). Errors: Protocol, naming the message type and field; LimitExceeded for a
/// message over MAX_TEXT_MESSAGE_BYTES or nested deeper than MAX_JSON_DEPTH.
Result<ClientMessage> parseClientMessage(std::string_view text);
/// The same for a value already parsed through parseJson (an HTTP body).
Result<ClientMessage> clientMessageFromJson(const nlohmann::json& j);
/// The `seq` of a message if it has a readable one, for an error reply to a refused message.
std::optional<uint64_t> peekSeq(std::string_view text);

std::string encode(const HelloMessage& m);
std::string encode(const EditMessage& m);
std::string encode(const UndoMessage& m);
std::string encode(const RedoMessage& m);
std::string encode(const TimeMessage& m);
std::string encode(const ViewMessage& m);
std::string encode(const PickMessage& m);
std::string encode(const PresenceMessage& m);
std::string encode(const DragMessage& m);
std::string encode(const AnnotateMessage& m);
std::string encode(const RestoreMessage& m);

// ---- server -> client ---------------------------------------------------------------------------
/// One connected client as presence reports it.
struct ClientInfo {
    uint64_t id = 0;
    std::string name;
    Role role = Role::Viewer;
    std::string editing; ///< empty: nothing
};
nlohmann::json toJson(const ClientInfo& c);

struct WelcomeInfo {
    uint64_t clientId = 0;
    Role role = Role::Viewer;
    std::string sessionId;
    nlohmann::json session; ///< the shot's description (resolution, camera, objects)
    Rig rig;
    ViewSettings view;
    std::vector<ClientInfo> clients;
    size_t undoDepth = 0;
    size_t redoDepth = 0;
    /// For editors only: the session's viewer token, so that an editor can hand reviewers a
    /// link that cannot edit (an editor already holds more than a viewer can do).
    std::optional<std::string> viewerToken;
};
std::string encodeWelcome(const WelcomeInfo& w);

/// `extra` fields are merged into the message (e.g. "view", "overwrote").
std::string encodeAck(uint64_t seq, uint64_t rigVersion, const nlohmann::json& extra = nlohmann::json::object());

/// How the rig changed: property changes, or a whole new rig (undo, redo, replace).
struct ChangeInfo {
    uint64_t rigVersion = 0;
    uint64_t byClient = 0;   ///< 0: a plain HTTP request
    std::string byName;
    std::string kind = "edit"; ///< "edit", "time", "undo", "redo" or "replace"
    std::vector<Change> changes;
    std::optional<Rig> rig;  ///< set for undo, redo and replace
};
std::string encodeChange(const ChangeInfo& c);
/// Several consecutive property changes (kinds "edit" and "time", oldest first, none with a
/// whole rig) as ONE change message: `changes` is their changes in order, `rigVersion`, `by` and
/// `byName` the newest's, `kind` "edit" (or "time" when all are), and, when there is more than
/// one, `versions` (the rig version each change of `changes` made, in step with it),
/// `coalesced` (how many) and `authors`: [{"by", "byName", "from", "to"}] (the versions each
/// author's changes span, in order). Applying `changes` in order gives the rig at `rigVersion`
/// (docs/protocol.md "change"): the server sends a busy session's changes so, at most one such
/// message per client per interval, instead of one message per change per client.
std::string encodeChanges(const std::vector<const ChangeInfo*>& changes);
nlohmann::json changesToJson(const std::vector<Change>& changes);

std::string encodeError(ErrorCode code, std::string_view message, std::optional<uint64_t> seq);
std::string encodePresence(const std::vector<ClientInfo>& clients);
std::string encodePickResult(uint64_t seq, const nlohmann::json& pick);

} // namespace dfb::protocol
