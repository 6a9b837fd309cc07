/**
 * Trajectory Service playground: ES modules, no build step, nothing fetched from another origin.
 * The page calls only the public API (``/v1/...`` and ``/openapi.json``), like any client, and
 * draws the answers with Plotly (vendored, ``/static/plotly.min.js``).
 *
 * Modules: one per panel or view (``cartesian_form``, ``cartesian_view``, ``compare``,
 * ``joint_form``, ``joint_view``, ``collision_free``, ``spline_form``, ``program_form``,
 * ``program_view``, ``ik``, ``workcell``, ``presets``, ``robot``), the shared pieces (``state``:
 * the selected robot and two shared values; ``api``: HTTP and batched FK; ``schema``: the
 * service's enums; ``status``; ``plot``, ``joints_plot``, ``scene``, ``shapes``, ``toolpath``,
 * ``clearance``, ``tabs``, ``dom``) and this entry, which wires them.
 *
 * For people and for the browser test alike: <body data-state> is "busy" while a request runs,
 * "done" after one and "ready" once the page has loaded; <body data-run> counts finished runs.
 */

import { buildCartesianForm, fillCartesianChoices, wireCartesianForm } from './cartesian_form.js';
import { redrawPath, runCartesian, wireCartesianView } from './cartesian_view.js';
import { runCollisionFree } from './collision_free.js';
import { wireCompare } from './compare.js';
import { $ } from './dom.js';
import { wireIk } from './ik.js';
import { buildJointForm, collisionFree, fillJointChoices, wireJointForm } from './joint_form.js';
import { runJoint } from './joint_view.js';
import { wireJointsPlot } from './joints_plot.js';
import { placeholder } from './plot.js';
import { wirePresets } from './presets.js';
import { buildProgramForm, fillProgramChoices, wireProgramForm } from './program_form.js';
import { redrawProgramPath, runProgram, wireProgramView } from './program_view.js';
import { loadRobots, selectRobot } from './robot.js';
import { loadSchema } from './schema.js';
import { wireArmBars } from './scene.js';
import { buildSplineForm, fillSplineChoices, wireSplineForm } from './spline_form.js';
import { onRobot, robotName } from './state.js';
import { setStatus } from './status.js';
import { wireTabs } from './tabs.js';
import { wireWorkcell } from './workcell.js';

function wireButtons() {
  document.querySelectorAll('button.png').forEach((b) => b.addEventListener('click', () => {
    const div = $(b.dataset.plot);
    if (!div.data) return;
    window.Plotly.downloadImage(div, { format: 'png', filename: `${robotName()}-${b.dataset.plot}`,
      width: div.clientWidth, height: div.clientHeight, scale: 2 });
  }));
  $('robot').addEventListener('change', (e) => {
    ['c-preset', 'j-preset', 'p-preset'].forEach((id) => { $(id).value = ''; });
    selectRobot(e.target.value);
  });
  $('show-geometry').addEventListener('change', () => redrawPath());
  $('form-cartesian').addEventListener('submit', (e) => { e.preventDefault(); runCartesian(); });
  $('form-joint').addEventListener('submit', (e) => {
    e.preventDefault();
    if (collisionFree()) runCollisionFree(); else runJoint('joint');
  });
  $('form-spline').addEventListener('submit', (e) => { e.preventDefault(); runJoint('spline'); });
  $('form-program').addEventListener('submit', (e) => { e.preventDefault(); runProgram(); });
}

function wire() {
  wireTabs();
  wireButtons();
  wireCartesianForm();
  wireCartesianView();
  wireCompare();
  wireIk();
  wireJointForm();
  wireJointsPlot();
  wireSplineForm();
  wireProgramForm();
  wireProgramView();
  wireWorkcell();
  wirePresets();
  wireArmBars();
  onRobot(() => {
    buildCartesianForm();
    buildJointForm();
    buildSplineForm();
    buildProgramForm();
  });
}

async function main() {
  document.body.dataset.state = 'busy';
  wire();
  ['plot-path', 'plot-deviation', 'plot-sigma'].forEach((d) =>
    placeholder(d, 'Plan a Cartesian line to see the tool path, deviation and σ'));
  placeholder('plot-joints', 'Plan a motion to see its joints');
  placeholder('plot-compare', 'Compare methods to see their deviation curves');
  placeholder('plot-program-path', 'Run a program (Program tab) to see its tool path');
  placeholder('plot-program-speed', 'Run a program to see where it slows down');
  try {
    if (!(await loadSchema())) setStatus('error', 'GET /openapi.json failed: the lists are empty.');
    fillCartesianChoices();
    fillJointChoices();
    fillSplineChoices();
    fillProgramChoices();
    await loadRobots();
  } finally {
    document.body.dataset.state = 'ready';
  }
}

if (typeof window.Plotly === 'undefined') {
  setStatus('error', 'Plotly did not load from /static/plotly.min.js (service/static/vendor/).');
} else {
  main();
}
