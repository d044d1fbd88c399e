"""A small atlas and route study shared by the atlas and route steps' tests: robust_design's
designed level gait and descending_design's gait, measured under robust_design's noise, and a
route of four level steps across a plate (run once per test session by the ``route_study``
fixture of tests/study/conftest.py)."""

#: the level gait's step [m] and period [s] (robust_design's design step, its best design)
DX_LEVEL, PERIOD_LEVEL = 1.176533444822156, 0.8851244906318175
#: its full map's spectral radius (the design step's variational value)
RHO_LEVEL = 0.236294305759782
#: descending_design's full-map spectral radius (its floquet step)
RHO_DESCEND = 0.22815494726697053

GAITS = """\
      - name: level
        start: [0.5479596132339642, 5.127230897230126, -2.573886303565416]
        gait:
          kind: sequence
          torque_frame: motor
          section: {theta1: 0.0, direction: either, theta2: 0.548}
          segments:
            - {until: time, value: 7.519090701371105e-08}
            - {until: free_end_y, value: 0.0, direction: rising, torque: 0.34936766154301463, clock: reset}
            - {until: time, value: 0.3595490305742456, magnets: swap, torque: -0.44095666216325524}
      - name: descend
        start: [-1.2410195771999735, 3.141805394182585, 7.739977215255689]
        gait:
          kind: sequence
          torque_frame: motor
          rise: -0.1
          section: {theta1: 0.0, direction: either, theta2: -1.241}
          segments:
            - {until: time, value: 7.519090701371105e-08}
            - {until: free_end_y, value: -0.1, direction: rising, torque: -0.2118, clock: reset}
            - {until: time, value: 0.2, magnets: swap, torque: 0.2118}
"""

ROUTE_STUDY = f"""\
schema_version: 1
name: route_small
robot: seed2009
integrator: {{method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}}
steps:
  - name: atlas
    kind: atlas
    tick: 0.001
    runs: 12
    max_cycles: 15
    seed: 30
    noise: {{timing: 1.0e-3, latency: 1.0e-3, parameters: {{mass: 0.01, com: 0.01, inertia: 0.01}}}}
    switches: {{runs: 12}}
    gaits:
{GAITS}  - name: route
    kind: route
    from: atlas
    walks: 60
    seed: 43
    max_steps: 8
    height_step: 0.1
    risk_weight: 10.0
wall:
  margin: 0.05
  regions:
    - outline: [[-0.5, -1.0], [6.5, -1.0], [6.5, 1.0], [-0.5, 1.0]]
  start: {{position: [0.0, 0.0], attached: A}}
  goal: {{position: [{4 * DX_LEVEL}, 0.0], radius: 0.05}}
"""
