"""Built-in scenes: ready-made models used by the CLI, tutorials and benchmarks."""
