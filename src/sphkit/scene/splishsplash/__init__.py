"""SPlisHSPlasH's JSON scenes, translated to sphkit's scene model.

:func:`from_splishsplash` reads SPlisHSPlasH's scene format (field names as SPlisHSPlasH spells
them, methods chosen by its numbers; see ``reference/splishsplash_scene_format.md``). A field
that is absent takes SPlisHSPlasH's default. Checked against SPlisHSPlasH's sources
(``SPlisHSPlasH/Simulation.cpp``, ``TimeManager``/``SceneLoader.cpp``, ``TimeStep.cpp``,
``WCSPH/TimeStepWCSPH.cpp``, ``PCISPH/TimeStepPCISPH.cpp``, ``PBF/TimeStepPBF.cpp``,
``IISPH/TimeStepIISPH.cpp``, ``DFSPH/TimeStepDFSPH.cpp``, ``Viscosity/ViscosityBase.cpp``,
``Viscosity/Viscosity_Standard.cpp``, ``XSPH.cpp``, ``Vorticity/VorticityBase.cpp``,
``Vorticity/MicropolarModel_Bender2017.cpp``, ``Simulator/SimulatorBase.cpp``,
``Simulator/StaticBoundarySimulator.cpp``, ``NonPressureForceRegistration.cpp``) and the scenes
shipped with pysplishsplash 2.19 (the solver defaults were also read back from its time-step
objects):

==========================  ===============================================================
``simulationMethod``        4 (DFSPH); 0 WCSPH, 1 PCISPH, 2 PBF, 3 IISPH and 4 DFSPH map to
                            ``pressure.method`` wcsph/pcisph/pbf/iisph/dfsph; 5 (Projective
                            Fluids) and 6 (ICSPH) are not supported
``PCISPH``, ``PBF``,        the selected solver's block: ``minIterations`` (PCISPH 3, the
``IISPH``, ``DFSPH``        others 2), ``maxIterations`` 100, ``maxError`` 0.01 (% of rho0);
                            DFSPH also ``maxIterationsV`` 100, ``maxErrorV`` 0.1 (%),
                            ``enableDivergenceSolver`` true; PBF ``velocityUpdateMethod`` 0
                            (0 first order, 1 second order). The blocks of solvers the scene
                            does not select are ignored quietly.
``boundaryHandlingMethod``  2 (Bender et al. 2019 volume maps); 0 Akinci et al. 2012
                            particles, 1 Koschier & Bender 2017 density maps and 2 map to
                            ``boundary.method`` akinci2012/koschier2017/bender2019; 3 (Nogina
                            and Sellan 2026) is not supported (checked only when the scene has
                            rigid bodies)
(boundary pressure)         no SPlisHSPlasH field (it mirrors the fluid pressure: Akinci's
                            one-sided term, the maps' ``-k_i grad rho_B``); a translated scene
                            takes sphkit's default of its boundary model, the more accurate
                            MLS extrapolation (akinci2012) or hydrostatic wall pressure (maps),
                            with which a side wall carries the weight of the fluid beside it
                            (``validation/README.md``, "Boundary pressure defaults");
                            ``configuration.boundary.pressure: mirror`` in sphkit's format is
                            SPlisHSPlasH's term
``particleRadius``          0.025 m
``gravitation``             (0, -9.81, 0) m/s^2
``timeStepSize``            0.001 s (initial step; the fixed step when ``cflMethod`` is 0)
``cflMethod``               1 (0: fixed step, 1: CFL, 2: CFL with iteration control,
                            ``configuration.time.iteration_control``: the last step shrunk by
                            10 % after more than 10 pressure iterations, grown by 10 % after
                            fewer than 5, never above the CFL step; WCSPH reports no
                            iterations, so its step grows by at most 10 % a step, as
                            SPlisHSPlasH's)
``cflFactor``               0.5
``cflMinTimeStepSize``      1e-4 s (hard-coded in older versions)
``cflMaxTimeStepSize``      0.005 s
``WCSPH.stiffness``         50 Pa (shipped scenes use 25,000 to 50,000); ``exponent`` 7
``kernel``, ``gradKernel``  WCSPH selects the cubic spline; 0 cubic, 1 Wendland quintic C2,
                            2 poly6, 3 spiky, 4 precomputed cubic (read as cubic). In 2D
                            SPlisHSPlasH knows only 0 (cubic) and 1 (Wendland) and falls back
                            to the cubic spline for any other number, as done here.
``density0``                1000 kg/m^3
``viscosityMethod``         0 (none); 1 Standard (``"Standard viscosity": {"viscosity": nu,
                            "viscosityBoundary": nu_b}``, nu default 0.01 m^2/s, kinematic),
                            the implicit models, each with its block of ``"viscosity"``,
                            ``"viscoMaxIter"``, ``"viscoMaxError"`` (default 0.01):
                            2 Bender and Koschier 2017 (``"Bender and Koschier 2017"``,
                            viscosity a factor in [0, 1], default 0.01, viscoMaxIter 50),
                            3 Peer et al. 2015 (``"Peer et al. 2015"``, factor, 50),
                            4 Peer et al. 2016 (``"Peer et al. 2016"``, factor, 50, also
                            ``"viscoMaxIterOmega"`` 50, ``"viscoMaxErrorOmega"`` 0.01),
                            5 Takahashi et al. 2015 (``"Takahashi et al. 2015 (improved)"``,
                            kinematic, 100), 6 Weiler et al. 2018 (``"Weiler et al. 2018"``,
                            kinematic, 100, also ``"viscosityBoundary"`` 0) (numbering of 2.16+;
                            the XSPH filter is no longer a viscosity method but the per-material
                            block ``"XSPH": {"xsph": c, "xsphBoundary": c_b}``, default 0)
``vorticityMethod``         0 (none); 1 micropolar model of Bender et al. 2017 (``"Bender et al.
                            2017": {"vorticity": nu_t, "viscosityOmega": zeta, "inertiaInverse":
                            1/Theta}``, defaults 0.01 m^2/s, 0.1 m^2, 0.5 1/m^2); 2 vorticity
                            confinement (``"Vorticity confinement": {"vorticity": epsilon}``,
                            default 0.01 m/s); 3 Liu et al. 2021 is not supported (numbering of
                            ``NonPressureForceRegistration.cpp``)
``surfaceTensionMethod``    0 (none); 1 Becker & Teschner 2007, 2 Akinci et al. 2013, 3 He et
                            al. 2014, each with its block ``{"surfaceTension": c,
                            "surfaceTensionBoundary": c_b}`` (defaults 0.05, 0.01; units in
                            :mod:`sphkit.surface_tension`); 5 Zorilla, Ritter et al. 2020
                            with ``surfaceTension`` (0.05) and the ``surfTZR*`` keys of its
                            block (``zorilla2020`` in the scene model; defaults in
                            :mod:`sphkit.surface_tension.zorilla2020`); 4 Jeske et al. 2023
                            with ``surfaceTension`` (0.05), ``surfaceTensionBoundary`` (0.01)
                            and ``surfaceTensionViscosity``/``ViscosityBoundary``/``XSPH``/
                            ``MaxIter``/``MaxError`` (``jeske2023`` block; 0, 0, 0, 100, 1e-3)
``dragMethod``              0 (none); 1 Macklin et al. 2014, 2 Gissler et al. 2017, with the
                            block ``{"drag": c}`` (default 0.01)
``stopAt``                  -1 (no end); mapped to ``time.until`` when > 0
``dataExportFPS``           25; mapped to ``output.fps``
``enablePartioExport``,     false; mapped to ``output.formats`` bgeo and vtk (neither set:
``enableVTKExport``         sphkit's default, vtk)
``particleAttributes``      ``"velocity;density"`` -> ``output.attributes`` (absent: sphkit's
                            default velocity, density, pressure)
``FluidModels``             ``particleFile`` (BGEO, PLY, VTK/VTU; relative to the scene file)
                            -> ``fluid_files``: ``translation``, ``scale`` (only the first
                            component, as SPlisHSPlasH), ``rotationAxis``/``rotationAngle``,
                            ``id``, ``initialVelocity``, ``initialAngularVelocity`` (these
                            replace the file's velocities, as in SPlisHSPlasH); OBJ meshes to
                            fill are not supported
``Emitters``                ``type`` 0 (box) / 1 (circle), ``width``/``height`` 5 (particles,
                            become ``width``/``height`` = n 2r), ``translation``,
                            ``rotationAxis``/``rotationAngle`` (forced about z in 2D, where every
                            emitter is a box of width 1 as in ``createEmitters``), ``velocity``
                            1, ``id``, ``emitStartTime`` 0, ``emitEndTime`` (none) ->
                            ``emitters`` (:mod:`sphkit.world.emitters`); the material's
                            ``maxEmitterParticles`` (10,000) -> ``max_particles``;
                            ``emitterReuseParticles`` with ``emitterBoxMin``/``emitterBoxMax``
                            ([-1, 1] on each axis) -> ``reuse_box`` of its emitters
==========================  ===============================================================

Older scenes (before 2.16) write solver and method parameters flat (``"stiffness"`` or
``"maxError"`` in ``Configuration``, ``"viscosity"`` in a material); those are read when the
namespaced block does not set them (pysplishsplash 2.19 itself reads the iterative solvers'
parameters only from their block). Fields that only matter to SPlisHSPlasH's GUI, exporters or
to methods the scene does not select are ignored quietly; any other field sphkit does not know
is reported in one ``UserWarning`` listing the field paths.

Fluid blocks. SPlisHSPlasH (``SimulatorBase::createFluidBlocks``, ``denseMode`` 0) turns a block
into the box ``lo = scale * start + translation``, ``hi = scale * end + translation`` and places
``n = round((hi - lo) / 2r) - 1`` particles per axis at ``lo + 2r + 2r j`` (j = 0 .. n-1), i.e.
one particle diameter inside the box on both sides (in 2D only x and y, at z = 0). sphkit's
lattice (first particle at ``start + r``, last at or below ``end - r``) reproduces exactly these
positions with the block ``start' = lo + r``, ``end' = lo + r + 2r n``. A block with n < 1 on an
axis holds no particle in SPlisHSPlasH either; it is left out with a warning. ``denseMode`` 1
and 2 become the lattices ``"layered"`` and ``"close_packed"`` of the block ``[lo + r, hi - r]``
(:func:`sphkit.geometry.sampling.dense_block` places SPlisHSPlasH's particles for its box
``[lo, hi]``; their volume is :func:`sphkit.core.kernels.block_volume` of that lattice, where
SPlisHSPlasH keeps ``0.8 (2r)^3`` for every mode).

Rigid bodies. Static walls become :class:`~sphkit.scene.schema.MeshBoundary` entries; the mesh
is scaled, then rotated (``rotationAngle`` in radians about ``rotationAxis``), then translated,
as in ``StaticBoundarySimulator``. ``geometryFile`` stays relative to the scene file
(``scene.source``). In 2D SPlisHSPlasH samples the mesh's section with the plane z = 0 before the
(in-plane) rotation and translation; sphkit intersects the placed mesh, which is the same for
rotations about z and translations in the xy-plane.

Joints. ``HingeJoints`` and ``TargetVelocityMotorHingeJoints`` (PositionBasedDynamics' blocks:
``bodyID1``, ``bodyID2`` naming ``RigidBodies[].id``, ``position``, ``axis``; the motor's
``target`` or ``targetSequence`` with ``repeatSequence``) become ``joints``
(:mod:`~sphkit.scene.splishsplash.joints`; the motor's target changes sign, see there); the other
joint blocks are refused by name.

Modules: :mod:`~sphkit.scene.splishsplash.translate` (the top level, :func:`from_splishsplash`,
:func:`is_splishsplash`), :mod:`~sphkit.scene.splishsplash.reader` (field readers, unknown
fields, field paths), :mod:`~sphkit.scene.splishsplash.configuration` (``Configuration``: solvers,
time step, export), :mod:`~sphkit.scene.splishsplash.materials` (viscosity, vorticity, surface
tension, drag), :mod:`~sphkit.scene.splishsplash.objects` (fluid blocks, fluid models, emitters,
rigid bodies), :mod:`~sphkit.scene.splishsplash.joints` (hinge joints and motors) and
:mod:`~sphkit.scene.splishsplash.methods` (every table of SPlisHSPlasH's method
numbers). Scene files are read by :mod:`sphkit.scene.files`, which calls the translator for a
scene in this format.
"""

from sphkit.scene.splishsplash.translate import from_splishsplash, is_splishsplash

__all__ = ["from_splishsplash", "is_splishsplash"]
