/** The form tabs (which task is edited) and the view tabs (which plots are shown). */

export function showView(name) {
  document.querySelectorAll('#view-tabs button').forEach((b) => {
    b.classList.toggle('active', b.dataset.view === name);
  });
  document.querySelectorAll('.view').forEach((v) => { v.hidden = v.dataset.view !== name; });
  document.querySelectorAll(`#view-${name} .plot`).forEach((div) => {
    if (div.data) window.Plotly.Plots.resize(div);
  });
}

export function showFormTab(name) {
  document.querySelectorAll('#form-tabs button').forEach((b) => {
    b.classList.toggle('active', b.dataset.tab === name);
  });
  document.querySelectorAll('.plan-form').forEach((f) => { f.hidden = f.dataset.tab !== name; });
}

/** Wire both tab bars. */
export function wireTabs() {
  document.querySelectorAll('#form-tabs button').forEach((b) =>
    b.addEventListener('click', () => showFormTab(b.dataset.tab)));
  document.querySelectorAll('#view-tabs button').forEach((b) =>
    b.addEventListener('click', () => showView(b.dataset.view)));
}
