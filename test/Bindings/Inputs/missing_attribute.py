"""Prints the exception each compiler raises for a missing attribute."""

from load_extension import load

compiler = load("_yasps_compiler")

# @e reads only @c, which is not a minimisation target: it gets no
# derivatives.
IR = """
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
      yasps.data_attr @c : !yasps.mat<1x1xf64>
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %c = yasps.read @m::@p::@c : !yasps.mat<1x1xf64>
        yasps.yield %c : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@x]
}
"""


def report(label, compile):
    try:
        compile()
    except compiler.MissingAttributeError as error:
        print(f"{label}: {type(error).__name__} {error.symbol} "
              f"{type(error).__mro__[1].__name__}")
    except compiler.IRError as error:
        print(f"{label}: {type(error).__name__}")


report("cpu", lambda: compiler.compile_cpu(
    IR, ["@m::@p::@e__grad"], pre_pipeline="yasps-differentiate-pipeline"))
report("gpu", lambda: compiler.compile_gpu(
    IR, ["@m::@p::@e__grad"], ["sm_90"],
    pre_pipeline="yasps-differentiate-pipeline"))
# A path that is not a symbol path is no missing attribute.
report("other", lambda: compiler.compile_cpu(IR, ["e__grad"]))
