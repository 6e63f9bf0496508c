"""What every command shares, below everything that uses it: exit codes and the one-line error, option types, the
progress bar."""
