"""The layering of loopsolve's imports and its documented exceptions (see ARCHITECTURE.md).

The layers, lowest first, are :data:`LAYERS`; a module may import its own layer and lower ones.
The exceptions: :data:`FACADE` (convenience methods that reach up), :data:`WITHIN_LAYER` (lazy imports
back inside a layer) and :data:`CYCLES` (import cycles inside a layer, each with its reason).
The convenience methods below live on objects of a lower layer (a :class:`Mechanism` is a
declaration, a :class:`Sweep` a kinematic result) but call into higher layers, always with an
import inside the method, so ``import loopsolve`` stays light and no import cycle forms at
module level. ``tests/test_import_layers.py`` checks that nothing else reaches up and that this
list names only imports that exist.
"""

LAYERS = ("errors", "model", "symbolic", "kinematics", "dynamics", "design", "output", "editor", "cli")

# (module, method, the subpackage.module it reaches up to)
FACADE = (
    ("model.mechanism", "Mechanism.derive", "symbolic.loop_equations"),
    ("model.mechanism", "Mechanism.compile", "symbolic.compiled"),
    ("model.mechanism", "Mechanism.solve", "kinematics.solve"),
    ("model.mechanism", "Mechanism.sweep", "kinematics.sweep"),
    ("model.mechanism", "Mechanism.modes", "kinematics.modes"),
    ("model.mechanism", "Mechanism.info", "kinematics.info"),
    ("model.mechanism", "Mechanism.derive_dynamics", "dynamics.eom"),
    ("model.mechanism", "Mechanism.forces", "dynamics.kinetostatics"),
    ("model.mechanism", "Mechanism.simulate", "dynamics.simulation"),
    ("model.mechanism", "Mechanism.draw", "output.plotting"),
    ("model.mechanism", "Mechanism.to_latex", "output.latex"),
    ("model.mechanism", "Mechanism._repr_latex_", "output.latex"),
    ("kinematics.results", "Sweep.plot", "output.plotting"),
    ("kinematics.results", "Sweep.animate", "output.plotting"),
    ("kinematics.results", "Sweep.to_html", "output.view"),
    ("kinematics.results", "Sweep.view", "output.view"),
    ("kinematics.results", "Sweep._repr_html_", "output.view"),
    ("dynamics.forceresults", "ForceSweep.plot_torque", "output.forceplots"),
    ("dynamics.forceresults", "ForceSweep.plot_joint_forces", "output.forceplots"),
    ("dynamics.forceresults", "ForceSweep.plot_shaking", "output.forceplots"),
    ("design.synthesis.run", "SynthesisResult.plot", "output.plotting"),
    ("design.synthesis.shape.run", "ShapeResult.plot", "output.shapeview"),
    ("design.synthesis.shape.run", "ShapeResult.to_html", "output.shapeview"),
    ("design.synthesis.shape.run", "ShapeResult.view", "output.view"),
)

# Inside a layer, a module may import one that imports it back only inside a function; these are
# all such back-references (module, the module it reaches back to, why), checked by the same test.
WITHIN_LAYER = (
    ("model.mechanism", "model.spec", "Mechanism's methods rebuild a declaration through build_mechanism"),
    ("model.diagram", "model.modelfile", "to_vector_model writes a model file; modelfile reads diagrams"),
    ("kinematics.solve", "kinematics.reach", "a failed solve names the nearest assemblable inputs"),
    ("kinematics.results", "kinematics.export", "Sweep.to_csv/to_json: the tables of a result"),
    ("kinematics.classic", "kinematics.classic_limits", "the old names C.grashof, C.quick_return, ... still answer"),
)

# Every import cycle inside a layer, imports inside functions included (the strongly connected
# components that tests/test_import_layers.py finds): (the modules, why they stay together). A cycle
# not listed here fails the test; a listed one that is broken must leave the list.
CYCLES = (
    (("model.mechanism", "model.spec"),
     "a Mechanism is built from a declaration, and its methods rebuild one through build_mechanism"),
    (("model.diagram", "model.modelfile"),
     "model files may be kinematic diagrams, and to_vector_model writes a diagram out as a model file"),
    (("model.cams", "model.pairs"),
     "pairs dispatches each section to its element module; the cam check evaluates parameters with pairs'"
     " evaluator"),
    (("kinematics.solve", "kinematics.modes", "kinematics.reach", "kinematics.continuation"),
     "a solve starts in a mode (modes) and, when it fails, names the nearest assemblable inputs (reach, which"
     " traces by continuation, whose trace starts with a solve)"),
    (("kinematics.results", "kinematics.export"), "Sweep.to_csv/to_json are the tables of a result"),
    (("kinematics.classic", "kinematics.classic_limits"), "the old names C.grashof, C.quick_return, ... still answer"),
)
