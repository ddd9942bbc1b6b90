// battery_dashboard's pages: the overview (index.html) and one battery (battery.html).
// The server formats every value (NaN arrives as "-"); the page only places text,
// classes and chart points. Data go in through textContent, never as HTML.
'use strict';

const FIELDS = ['percentage', 'status', 'voltage', 'current', 'temperature', 'time_remaining'];
let faultNames = [];   // the simulator's faults, from the server's snapshot (core/status_codes.py)
const CHART_FIELDS = {percentage: '#2e7d32', voltage: '#1565c0', current: '#6a1b9a', temperature: '#e65100'};

// The server's clock against ours: ages are shown from the server's own times.
let serverOffsetS = 0;
function serverNow() { return Date.now() / 1000 + serverOffsetS; }

function displayName(topic) {
  const name = topic.replace(/^\/+/, '');
  return name.endsWith('/battery_status') ? name.slice(0, -'/battery_status'.length) : name;
}

function ageText(seconds) {
  if (seconds === null || !isFinite(seconds)) return '-';
  if (seconds < 0) seconds = 0;
  if (seconds < 60) return seconds.toFixed(seconds < 10 ? 1 : 0) + ' s ago';
  if (seconds < 3600) return Math.round(seconds / 60) + ' min ago';
  return (seconds / 3600).toFixed(1) + ' h ago';
}

function minutesAgo(time) {
  const minutes = Math.round((serverNow() - time) / 60);
  return minutes <= 0 ? 'now' : '-' + minutes + ' min';
}

function element(tag, className, text) {
  const node = document.createElement(tag);
  if (className) node.className = className;
  if (text !== undefined) node.textContent = text;
  return node;
}

// Level bar, icon and the low / critical / stale marks shared by both pages.
function showLevel(root, battery) {
  const level = battery.level === null ? 0 : Math.max(0, Math.min(100, battery.level));
  for (const fill of root.querySelectorAll('.bar-fill, .icon-fill')) fill.style.width = level + '%';
  root.classList.toggle('low', battery.low);
  root.classList.toggle('critical', battery.critical);
  root.classList.toggle('stale', battery.stale);
  root.classList.toggle('charging', battery.fields.status === 'Charging');
  root.classList.toggle('unknown', battery.level === null);
  const badges = root.querySelector('.badges');
  badges.textContent = '';
  for (const [on, name, text] of [[battery.critical, 'critical', 'CRITICAL'], [battery.low && !battery.critical, 'low', 'LOW'],
                                  [battery.stale, 'stale', 'STALE'], [battery.fields.status === 'Charging', 'charging', 'CHARGING'],
                                  [!['Good', '-'].includes(battery.fields.health), 'health', battery.fields.health.toUpperCase()],
                                  [((battery.sim || {}).active_faults || []).length > 0, 'fault', 'FAULT']]) {
    if (on) badges.appendChild(element('span', 'badge badge-' + name, text));
  }
}

function showFields(root, battery) {
  const outOfRange = battery.out_of_range || [];
  for (const field of FIELDS) {
    const node = root.querySelector('[data-field="' + field + '"]');
    if (!node) continue;
    if (node.textContent !== battery.fields[field]) node.textContent = battery.fields[field];
    node.classList.toggle('out-of-range', outOfRange.includes(field));   // the text says "(out of range)" too
  }
}

// The live channel: a snapshot, then changes; reconnects after a drop.
function connect(onMessage) {
  const connection = document.getElementById('connection');
  const socket = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/live');
  socket.onopen = () => { connection.dataset.state = 'live'; connection.textContent = 'live'; };
  socket.onmessage = (event) => {
    const message = JSON.parse(event.data);
    serverOffsetS = message.now - Date.now() / 1000;
    onMessage(message);
  };
  socket.onclose = () => {
    connection.dataset.state = 'lost';
    connection.textContent = 'reconnecting...';
    setTimeout(() => connect(onMessage), 1000);
  };
}

// -- the overview ---------------------------------------------------------------

function overviewPage() {
  const list = document.getElementById('batteries');
  const cards = new Map();   // topic -> {node, battery}

  function makeCard(topic) {
    const card = element('a', 'battery');
    card.dataset.battery = topic;
    card.href = '/battery?topic=' + encodeURIComponent(topic);
    const head = element('div', 'head');
    const icon = element('span', 'icon');
    icon.appendChild(element('span', 'icon-fill'));
    head.append(icon, element('span', 'name', displayName(topic)), element('span', 'badges'));
    const level = element('div', 'level');
    const bar = element('div', 'bar');
    bar.appendChild(element('div', 'bar-fill'));
    level.append(element('span', 'big', '-'), bar);
    level.firstChild.dataset.field = 'percentage';
    const fields = element('dl', 'fields');
    for (const [label, field] of [['Status', 'status'], ['Voltage', 'voltage'], ['Current', 'current'],
                                  ['Temperature', 'temperature'], ['Remaining', 'time_remaining']]) {
      const value = element('dd', null, '-');
      value.dataset.field = field;
      fields.append(element('dt', null, label), value);
    }
    const foot = element('div', 'foot');
    foot.append(element('span', 'topic', topic), element('span', 'updated', '-'));
    card.append(head, level, fields, foot);
    return card;
  }

  // the cards in the server's natural order (robot2 before robot10): each battery's 'order' is a key whose
  // plain string order is that order (dashboard_texts.natural_key)
  function place(order, card) {
    let next = null;
    for (const entry of cards.values()) {
      if (entry.order > order && (next === null || entry.order < next.order)) next = entry;
    }
    list.insertBefore(card, next === null ? null : next.node);
  }

  function show(battery) {
    let entry = cards.get(battery.topic);
    if (!entry) {
      const node = makeCard(battery.topic);
      const order = battery.order || battery.topic;
      place(order, node);
      entry = {node, order};
      cards.set(battery.topic, entry);
    }
    entry.battery = battery;
    showFields(entry.node, battery);
    showLevel(entry.node, battery);
  }

  function summarize() {
    const all = [...cards.values()].map((entry) => entry.battery);
    const count = (test) => all.filter(test).length;
    document.getElementById('summary').textContent = all.length + (all.length === 1 ? ' battery' : ' batteries') +
      ' \u00b7 ' + count((b) => b.fields.status === 'Charging') + ' charging \u00b7 ' +
      count((b) => b.low && !b.critical) + ' low \u00b7 ' + count((b) => b.critical) + ' critical \u00b7 ' +
      count((b) => b.stale) + ' stale';
    document.getElementById('empty').hidden = all.length > 0;
  }

  function ages() {
    const now = serverNow();
    for (const entry of cards.values()) {
      const last = entry.battery.last_message;
      entry.node.querySelector('.updated').textContent = last === null ? 'no message yet' : 'updated ' + ageText(now - last);
    }
  }

  connect((message) => {
    if (message.type === 'snapshot') {
      const present = new Set(message.batteries.map((b) => b.topic));
      for (const [topic, entry] of cards) {
        if (!present.has(topic)) { entry.node.remove(); cards.delete(topic); }
      }
    }
    for (const battery of message.batteries) show(battery);
    for (const topic of message.removed || []) {
      const entry = cards.get(topic);
      if (entry) { entry.node.remove(); cards.delete(topic); }
    }
    summarize();
    ages();
  });
  setInterval(ages, 1000);
}

// -- one battery -----------------------------------------------------------------

function batteryPage() {
  const topic = new URLSearchParams(location.search).get('topic') || '';
  const root = document.getElementById('battery');
  root.dataset.battery = topic;
  document.getElementById('title').textContent = displayName(topic);
  document.title = displayName(topic) + ' - battery_dashboard';
  let historyS = 600;
  let lastPoint = null;
  let latest = null;
  const charts = {};
  window.batteryCharts = charts;   // for tests and the curious: the Chart.js instances

  const chartLibrary = typeof Chart !== 'undefined';
  if (!chartLibrary) {   // the distribution's chart library is missing: say so where the charts would be
    for (const canvas of document.querySelectorAll('canvas[data-chart]')) {
      const note = element('p', 'chart-missing', 'No chart: the chart library is missing (install the Debian '
                           + 'package libjs-chart.js, which puts it in /usr/share/javascript/chart.js).');
      note.dataset.chartMissing = canvas.dataset.chart;
      canvas.replaceWith(note);
    }
  }
  for (const [field, colour] of Object.entries(chartLibrary ? CHART_FIELDS : {})) {
    const canvas = document.querySelector('canvas[data-chart="' + field + '"]');
    charts[field] = new Chart(canvas, {
      type: 'line',
      data: {datasets: [{data: [], borderColor: colour, backgroundColor: colour + '22', fill: field === 'percentage',
                         borderWidth: 2, pointRadius: 0, spanGaps: false}]},
      options: {
        animation: false, parsing: false, normalized: true, maintainAspectRatio: false,
        plugins: {legend: {display: false}, tooltip: {enabled: true, intersect: false, mode: 'index',
          callbacks: {title: (items) => ageText(serverNow() - items[0].parsed.x)}}},
        scales: {
          x: {type: 'linear', ticks: {maxTicksLimit: 7, callback: minutesAgo}},
          y: field === 'percentage' ? {min: 0, max: 100} : {grace: '5%'},
        },
      },
    });
  }

  function setRange() {
    const now = serverNow();
    for (const chart of Object.values(charts)) {
      chart.options.scales.x.min = now - historyS;
      chart.options.scales.x.max = now;
      const data = chart.data.datasets[0].data;
      while (data.length && data[0].x < now - historyS) data.shift();
      chart.canvas.dataset.points = data.length;
      chart.update('none');
    }
  }

  function addPoint(t, values) {
    for (const field of Object.keys(charts)) {
      const y = values[field];
      charts[field].data.datasets[0].data.push({x: t, y: y === null || y === undefined ? NaN : y});
    }
    lastPoint = t;
  }

  function showDetail(battery) {
    latest = battery;
    document.getElementById('missing').hidden = true;
    root.hidden = false;
    showFields(root, battery);
    showLevel(root, battery);
    const sim = battery.sim || {};
    const outOfRange = battery.out_of_range || [];
    const text = (field, value) => {
      const node = root.querySelector('[data-field="' + field + '"]');
      node.textContent = value;
      node.classList.toggle('out-of-range', outOfRange.includes(field));
    };
    for (const field of ['charge', 'capacity', 'health', 'cycle_count', 'state_of_health']) text(field, battery.fields[field]);
    text('faults', sim.active_faults === undefined ? '-' : (sim.active_faults.join(', ') || 'none'));
    text('cut_off', sim.cut_off === undefined ? '-' : (sim.cut_off || 'none'));
    text('period', battery.period_s ? battery.period_s.toFixed(2) + ' s' : '-');
    text('host', battery.host || '-');
    showControls(battery);
    if (battery.last_message !== null && (lastPoint === null || battery.last_message > lastPoint)) {
      addPoint(battery.last_message, {percentage: battery.level, voltage: battery.values && battery.values.voltage,
                                      current: battery.values && battery.values.current,
                                      temperature: battery.values && battery.values.temperature});
      setRange();
    }
  }

  let controlsOn = false;
  function showControls(battery) {
    const section = document.getElementById('controls');
    if (!section) return;   // read-only: the server leaves the controls out
    section.hidden = !(controlsOn && battery.controls);
    const active = (battery.sim && battery.sim.active_faults) || [];
    for (const button of document.querySelectorAll('#faults button')) {
      const on = active.includes(button.dataset.fault);
      button.classList.toggle('active', on);
      button.textContent = (on ? 'Clear ' : 'Inject ') + button.dataset.fault.replace('_', ' ');
    }
  }

  async function control(body) {
    const result = document.getElementById('control-result');
    result.textContent = 'sending...';
    result.className = 'result';
    try {
      const response = await fetch('/api/control', {method: 'POST', headers: {'Content-Type': 'application/json'},
                                                     body: JSON.stringify(Object.assign({topic}, body))});
      const answer = await response.json();
      result.textContent = answer.message || (answer.success ? 'done' : 'refused');
      result.className = 'result ' + (answer.success ? 'ok' : 'error');
    } catch (error) {
      result.textContent = String(error);
      result.className = 'result error';
    }
  }

  if (document.getElementById('controls')) {   // read-only pages have none
    const form = document.getElementById('set-state');
    form.addEventListener('submit', (event) => {
      event.preventDefault();
      const result = document.getElementById('control-result');
      if (!form.checkValidity()) { form.reportValidity(); result.textContent = 'a value is out of range'; result.className = 'result error'; return; }
      const body = {action: 'set_state'};
      for (const input of form.querySelectorAll('input')) body[input.name] = input.value === '' ? '' : Number(input.value);
      if (['percentage', 'temperature_c', 'state_of_health'].every((name) => body[name] === '')) {
        result.textContent = 'enter at least one value'; result.className = 'result error'; return;
      }
      control(body);
    });
    for (const button of document.querySelectorAll('button[data-control="set_charging"]')) {
      button.addEventListener('click', () => control({action: 'set_charging', charging: button.dataset.charging === 'true'}));
    }
  }

  // One button per fault the simulator knows (the server's snapshot lists them: core/status_codes.py).
  function makeFaultButtons() {
    const faults = document.getElementById('faults');
    if (!faults || faults.dataset.made) return;   // a read-only page has no controls
    faults.dataset.made = 'true';
    for (const fault of faultNames) {
      const button = element('button', 'fault', 'Inject ' + fault.replace('_', ' '));
      button.type = 'button';
      button.dataset.fault = fault;
      button.addEventListener('click', () => control({action: 'inject_fault', fault,
                                                       active: !(latest && latest.sim && (latest.sim.active_faults || []).includes(fault))}));
      faults.appendChild(button);
    }
  }

  function ages() {
    if (latest) {
      root.querySelector('[data-field="updated"]').textContent =
        latest.last_message === null ? 'no message yet' : ageText(serverNow() - latest.last_message);
    }
  }

  fetch('/api/history?topic=' + encodeURIComponent(topic)).then((response) => response.json()).then((answer) => {
    if (!answer.history) return;
    historyS = answer.history_s;
    const h = answer.history;
    const keep = lastPoint;   // points the live channel already brought stay after the history
    for (const chart of Object.values(charts)) chart.data.datasets[0].data = [];
    lastPoint = null;
    for (let i = 0; i < h.t.length; i++) {
      addPoint(h.t[i], {percentage: h.percentage[i], voltage: h.voltage[i], current: h.current[i], temperature: h.temperature[i]});
    }
    if (keep !== null && latest && (lastPoint === null || keep > lastPoint)) {
      addPoint(keep, {percentage: latest.level, voltage: latest.values.voltage, current: latest.values.current,
                      temperature: latest.values.temperature});
    }
    setRange();
  });

  connect((message) => {
    if (message.type === 'snapshot') {
      historyS = message.history_s;
      controlsOn = message.allow_control;
      faultNames = message.faults || [];
      makeFaultButtons();
      const battery = message.batteries.find((b) => b.topic === topic);
      if (battery) showDetail(battery);
      else { document.getElementById('missing').hidden = false; }
    } else {
      for (const battery of message.batteries) if (battery.topic === topic) showDetail(battery);
      if ((message.removed || []).includes(topic)) document.getElementById('missing').hidden = false;
    }
    ages();
  });
  setInterval(() => { setRange(); ages(); }, 1000);
}

document.addEventListener('DOMContentLoaded', () => {
  if (document.body.dataset.page === 'battery') batteryPage();
  else overviewPage();
});
