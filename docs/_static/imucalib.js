// The page menu's long object names (imucalib.methods._pose_table.calibrate_pose_table()) may break after
// a dot or an underscore, where a reader expects it, instead of in the middle of a word.
document.addEventListener("DOMContentLoaded", () => {
  for (const span of document.querySelectorAll(".bd-sidebar-secondary code span.pre")) {
    const parts = span.textContent.split(/(?<=[._])/);
    if (parts.length < 2) continue;
    span.textContent = "";
    parts.forEach((part, i) => {
      if (i) span.appendChild(document.createElement("wbr"));
      span.appendChild(document.createTextNode(part));
    });
  }
});
