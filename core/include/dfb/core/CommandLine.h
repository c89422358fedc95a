#pragma once
// How every program reads its command line (CLI11; docs/operations.md "Exit codes"): --help and
// --version print and exit 0; anything else wrong is a usage error, exit 1, told on stderr as
// "PROGRAM: what was wrong" with a pointer to --help. An unknown subcommand is named together
// with the ones there are (CLI11 alone says "A subcommand is required"). Header-only: only the
// programs, which link CLI11, include it.

#include <CLI/CLI.hpp>

#include <iostream>
#include <string>

namespace dfb {

/// The exit code of a command-line (usage) error, the same in every program.
constexpr int EXIT_COMMAND_LINE = 1;

namespace detail {
// The innermost subcommand the parse reached (the app itself when none).
inline CLI::App* deepestParsed(CLI::App& app) {
    CLI::App* cur = &app;
    for (;;) {
        CLI::App* next = nullptr;
        for (CLI::App* c : cur->get_subcommands()) next = c;
        if (!next) return cur;
        cur = next;
    }
}
} // namespace detail

/// Parses argv into `app`. Returns -1 to go on, or the code the program exits with (0 after
/// --help or --version, EXIT_COMMAND_LINE after a usage error, which is printed).
inline int parseCommandLine(CLI::App& app, int argc, const char* const* argv, const std::string& program) {
    try {
        app.parse(argc, argv);
        return -1;
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::string message = e.what();
        CLI::App* at = detail::deepestParsed(app);
        const auto subcommands = at->get_subcommands({});
        std::string word, option;
        for (const std::string& r : app.remaining()) {
            if (r.size() > 1 && r[0] == '-') {
                if (option.empty()) option = r;
            } else if (!r.empty() && word.empty()) {
                word = r;
            }
        }
        std::string where = at == &app ? program : program + " " + at->get_name();
        if (!option.empty()) {
            // An unknown option is the likelier mistake than what CLI11 found missing after it.
            message = "unknown option '" + option + "'";
        } else if (!subcommands.empty()) {
            // The parse stopped where a subcommand was due (the deepest one reached has none).
            std::string names;
            for (const CLI::App* c : subcommands) names += (names.empty() ? "" : ", ") + c->get_name();
            if (!word.empty()) message = "unknown subcommand '" + word + "' (" + where + " has: " + names + ")";
            else if (message == "A subcommand is required") message = "give a subcommand: " + names;
        }
        std::cerr << program << ": " << message << "\nRun '" << where << " --help' for more information.\n";
        return EXIT_COMMAND_LINE;
    }
}

} // namespace dfb
