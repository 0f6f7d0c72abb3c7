"""MoveIt's benchmarks (moveit_ros_benchmarks): ``moveit_run_benchmark`` plans every query of a
benchmark_config ``runs`` times with every planner of every pipeline, in-process, on local
processes or Ray workers, and writes OMPL's benchmark logs, the Planner Arena database and plots.

Modules, as MoveIt names them: benchmark_options (BenchmarkOptions), benchmark_queries (scenes,
queries, start states), benchmark_executor (BenchmarkExecutor: runs and their figures),
benchmark_log (OMPL's log format), benchmark_statistics (moveit_benchmark_statistics.py: the
database and plots), distribution (local processes or Ray), run_benchmark (RunBenchmark) and
__main__ (the command). docs/benchmarking.md tells the story.
"""
