// The commands of the cbdpt command line, one file each (render_command.cpp, ...). A command's
// add function adds its subcommand and options to the app and returns how to run it.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace cb::cli {

struct Command {
    CLI::App* subcommand = nullptr;
    std::function<int()> run; // called after parsing when `subcommand` was given
};

Command addRenderCommand(CLI::App& app);
Command addCompareCommand(CLI::App& app);
Command addInfoCommand(CLI::App& app);
Command addMergeCommand(CLI::App& app);

} // namespace cb::cli
