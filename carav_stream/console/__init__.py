"""What every command shares: exit codes and the one-line error, option types, the progress bar. Only the commands
(carav_stream/cli/, and the benchmarks outside the package) use it; every other package raises its own errors and
takes progress callbacks (the import-linter contract "only the commands use console")."""
