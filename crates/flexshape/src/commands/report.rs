//! `flexshape report`: figures of a tracking output.

use crate::cli::ReportArgs;

pub fn run(args: &ReportArgs) -> anyhow::Result<()> {
    let records: Vec<_> = flexshape_record::read_records(&args.data)?
        .into_iter()
        .map(|(_, r)| r)
        .collect();
    let files = flexshape_validate::figures::report(&args.out, &records)?;
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
