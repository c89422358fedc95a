#pragma once
// Expected failures are values (OpenEXR Core's exr_result_t): a Result<T> holds either a value or
// an Error with a code and a message naming the file or object and what was wrong.

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace dfb {

/// What kind of expected failure occurred. Stable: codes appear in logs and protocol errors.
enum class ErrorCode {
    Ok = 0,
    FileNotFound,  ///< a path does not exist or cannot be opened
    InvalidFile,   ///< the file exists but is not of the expected format or is corrupt
    MissingData,   ///< a required channel, attribute, mesh or camera is absent
    InvalidValue,  ///< a value is out of range, NaN or of the wrong type
    GpuError,      ///< the GL/EGL context could not be created, was lost, or a GL call failed
    IoError,       ///< writing or reading failed part way
    Network,       ///< a connection failed or was closed
    Protocol,      ///< a peer sent a message that does not follow the protocol
    Unauthorized,  ///< no token, or a token that opens nothing (HTTP 401)
    Forbidden,     ///< the token is valid but its role may not do this (a viewer editing; HTTP 403)
    Conflict,      ///< a precondition on the rig version failed (If-Match, `ifVersion`; HTTP 412)
    LimitExceeded, ///< an input or a rig is over a configured limit; the message names it and its value
    Unavailable,   ///< the session cannot serve now (its journal is damaged, it failed to load; HTTP 503)
    Moved,         ///< (last: errorCodeFromString walks up to it) another node holds the session's lease (HTTP 503 + Retry-After: retry through the router)
};

/// Short stable name of an error code (used in protocol error messages).
inline const char* toString(ErrorCode code) {
    switch (code) {
    case ErrorCode::Ok: return "ok";
    case ErrorCode::FileNotFound: return "file_not_found";
    case ErrorCode::InvalidFile: return "invalid_file";
    case ErrorCode::MissingData: return "missing_data";
    case ErrorCode::InvalidValue: return "invalid_value";
    case ErrorCode::GpuError: return "gpu_error";
    case ErrorCode::IoError: return "io_error";
    case ErrorCode::Network: return "network";
    case ErrorCode::Protocol: return "protocol";
    case ErrorCode::Unauthorized: return "unauthorized";
    case ErrorCode::Forbidden: return "forbidden";
    case ErrorCode::Conflict: return "conflict";
    case ErrorCode::LimitExceeded: return "limit_exceeded";
    case ErrorCode::Unavailable: return "unavailable";
    case ErrorCode::Moved: return "moved";
    }
    return "unknown";
}

/// The code named `name` (as toString writes it); nullopt for an unknown name.
inline std::optional<ErrorCode> errorCodeFromString(std::string_view name) {
    for (int c = int(ErrorCode::Ok); c <= int(ErrorCode::Moved); ++c) {
        if (name == toString(ErrorCode(c))) return ErrorCode(c);
    }
    return std::nullopt;
}

/// An expected failure: a code and a human-readable message naming the object and the problem.
struct Error {
    ErrorCode code = ErrorCode::Ok;
    std::string message;

    std::string toString() const { return std::string(dfb::toString(code)) + ": " + message; }
};

/// Either a T or an Error. Cheap to move; check ok() before value().
template <typename T> class Result {
public:
    Result(T value) : mData(std::move(value)) {}
    Result(Error error) : mData(std::move(error)) {}

    bool ok() const { return std::holds_alternative<T>(mData); }
    explicit operator bool() const { return ok(); }

    T& value() & { return std::get<T>(mData); }
    const T& value() const& { return std::get<T>(mData); }
    T&& value() && { return std::get<T>(std::move(mData)); }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }
    T& operator*() { return value(); }

    const Error& error() const { return std::get<Error>(mData); }

private:
    std::variant<T, Error> mData;
};

/// Result of an operation that produces no value.
struct Unit {};
using Status = Result<Unit>;
inline Status okStatus() { return Unit{}; }

inline Error makeError(ErrorCode code, std::string message) {
    return Error{code, std::move(message)};
}

} // namespace dfb
