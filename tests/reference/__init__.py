"""Independent plain NumPy/SciPy references for judging the vcavity simulator.

Nothing in this package imports vcavity's physics (``vcavity.microfacet``,
``vcavity.facet``, ``vcavity.sensor.binning``, ``vcavity.kernels``, ``vcavity.analytic``,
``vcavity.sensor.grid``): every formula is written again from docs/physics.md and the
textbooks it cites, so a bug in the package's parameter packing, normal samplers,
Fresnel code, sensor or walk cannot be shared by the reference that judges it.

Modules
-------
materials
    Closed-form ``D(m)`` of every distribution from a config-style material dict,
    textbook Fresnel (Snell + amplitudes), ``r_e``, ``r_i``, IL body constant,
    V-cavity ``G1``/``G2``, and a deterministic quadrature over normals.
sensor
    The equal-area concentric sensor from its definition: map, inverse map, binning,
    per-cell quadrature in the square (diagonal cells split into triangles).
single_bounce
    Exact expectation of the simulated ``f1`` per cell (specular + IL body).
groove_paths
    A 2-D V-groove tracer (explicit line intersections, checked against unfolding)
    and ``f_k`` per cell for mirror and ``kd = 0`` dielectric facets.
lambertian_orders
    Order-1 and order-2 albedos of Lambertian facets from 2-D view factors.
numpy_walk
    The plain-NumPy vectorised walk (the throughput baseline of scripts/bench_throughput.py).
merl_reader
    A MERL BRDF reader written from the format's description (header, bin index, colour
    scales, half/difference angles), for the MERL export's round trip.
tensor_file_reader
    A reader of the RGL ``tensor_file`` container, for the RGL export's tests.
cycles_tables
    Blender Cycles' ``table_ggx_E`` and ``table_ggx_Eavg`` quoted as shipped
    (``data/cycles_ggx_E.tables``) and their parser, for the Cycles-layout comparison.
smith_albedo
    The single-scattering albedo of GGX mirror facets with the height-correlated Smith G2
    by deterministic quadrature: what Cycles' table estimates, for judging differences.
"""
