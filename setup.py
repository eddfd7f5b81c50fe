"""The one compiled part: sim/pd_ticks.c, the servo loop's PD ticks (sim/pd_ticks.py).

Optional: without a C compiler (or on a platform where it fails to build) ``pip install .``
carries on without it and the servo loop runs its pure-Python ticks, which give the same numbers
bit for bit -- the compiled ticks only make the loop faster (benchmarks/bench_sim.py).
Everything else about the package is in pyproject.toml.
"""

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext


class BuildExt(build_ext):
    """No fused multiply-add (-ffp-contract=off): the C law must round as Python's floats do."""

    def build_extensions(self) -> None:
        if self.compiler.compiler_type != "msvc":  # MSVC does not contract by default
            for ext in self.extensions:
                ext.extra_compile_args = ["-O2", "-ffp-contract=off", "-fno-fast-math"]
        super().build_extensions()


setup(
    ext_modules=[Extension("gantry_sim.sim._pd_ticks", ["sim/pd_ticks.c"], optional=True)],
    cmdclass={"build_ext": BuildExt},
)
