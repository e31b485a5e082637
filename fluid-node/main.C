/*---------------------------------------------------------------------------*\
    hemocosim-fluid: the fluid node of a hemocosim run (OpenFOAM v1912).
    SPDX-License-Identifier: GPL-3.0-or-later

Description
    Volume-averaged incompressible Navier-Stokes of plasma in a periodic
    straight vessel (docs/model.md section 1), PISO, coupled in lockstep with a
    particle node over the run's message bus:

        d(alpha U)/dt + div(alpha phi U) - div(alpha nu grad U)
            = -alpha grad p + alpha G + S/rho - (K/rho) U
        d(alpha)/dt + div(alpha U) = 0

    alpha = 1 - phi_solid, K the implicit drag coefficient and S the explicit
    momentum source from the particles, G = dP/(rho l) e_z the driving force.

    Decomposed (--parallel, under mpirun): one subdomain per rank; the master
    alone holds the node's port and hands orders and feedback to every rank;
    every rank publishes its own cells' state to the particle ranks that need
    them (the partitioned exchange; fluidLink.H, publishState.H).

    Checkpoints: the order of a step may ask for the whole state at its end
    (writeCheckpoint.H); --resume-step K starts from that of step K (restoreCheckpoint.H).

Usage
    hemocosim-fluid --scene FILE --run-dir DIR [bus options] [--ranks N] [--resume-step K]
\*---------------------------------------------------------------------------*/

// hemocosim's own headers first: they must not see OpenFOAM's macros.
#include "fluidNode.H"

#include "fvCFD.H"
#include "pisoControl.H"
#include "constrainPressure.H"
#include "fluidLink.H"
#include "fluidCheckpoint.H"

int main(int argc, char* argv[])
{
    #include "parseOptions.H"
    #include "startParallel.H"
    #include "createPort.H"

    try
    {
        #include "writeCase.H"
        #include "createTime.H"
        #include "createMesh.H"
        #include "createFields.H"
        #include "feedbackFields.H"
        #include "checkpointedFields.H"
        #include "restoreCheckpoint.H"

        port.followBoxes(scene);
        port.initialize(meshMsg, globalCell, rankCells);
        #include "publishState.H"

        while (auto step = port.advance(state, localState, diagnostics))
        {
            #include "advanceTime.H"
            #include "applyFeedback.H"
            #include "fluidStep.H"

            if (fluidSteady || !solveNow)
            {
                // One-way scene, steady flow: nothing can change it; or (fluid.solve_every) a
                // step inside a fluid step of several intervals: publish the last state again.
                #include "republishSteady.H"
            }
            else
            {
                resumedDiagnostics.clear();     // the solve reports its own
                auto phaseStart = std::chrono::steady_clock::now();

                // PISO: momentum predictor, then pressure correctors (nCorrectors, and more
                // while the pressure equation is still inconsistent: see createFields.H)
                #include "UEqn.H"
                const double momentumSeconds = hemo::seconds_since(phaseStart);
                phaseStart = std::chrono::steady_clock::now();
                for (pisoCorr = 1; ; ++pisoCorr)
                {
                    #include "pEqn.H"
                    if (finalCorrector) break;
                }
                const double pressureSeconds = hemo::seconds_since(phaseStart);
                ++fluidSolves;

                phaseStart = std::chrono::steady_clock::now();
                #include "momentumBudget.H"
                #include "diagnostics.H"
                #include "steadyCheck.H"
                #include "holdBack.H"
                const double diagnosticsSeconds = hemo::seconds_since(phaseStart);
                phaseStart = std::chrono::steady_clock::now();
                #include "publishState.H"
                const double publishSeconds = hemo::seconds_since(phaseStart);

                hemo::set_diagnostic(diagnostics, "fluid_solved", 1);
                hemo::set_diagnostic(diagnostics, "fluid_solves", scalar(fluidSolves));
                hemo::set_diagnostic(diagnostics, "phase_fluid_momentum_s", momentumSeconds);
                hemo::set_diagnostic(diagnostics, "phase_fluid_pressure_s", pressureSeconds);
                hemo::set_diagnostic(diagnostics, "phase_fluid_diagnostics_s", diagnosticsSeconds);
                hemo::set_diagnostic(diagnostics, "phase_fluid_publish_s", publishSeconds);
                if (solveEvery > 1)
                {
                    hemo::set_diagnostic(diagnostics, "fluid_step_s", fluidStepSeconds);
                    hemo::set_diagnostic(diagnostics, "applied_source_x_N", appliedSource.x());
                    hemo::set_diagnostic(diagnostics, "applied_source_y_N", appliedSource.y());
                    hemo::set_diagnostic(diagnostics, "applied_source_z_N", appliedSource.z());
                }
            }

            if (step->order.write_output)
            {
                #include "writeOutput.H"
            }
            if (step->order.write_checkpoint)
            {
                #include "writeCheckpoint.H"
            }
        }

        // The coordinator said stop: keep the final state.
        #include "writeOutput.H"
        port.finalize();
        Info<< "hemocosim-fluid: finished at t = " << runTime.timeName() << " s" << endl;
    }
    catch (const Foam::error& err)
    {
        return finish(hemo::fluid_failed(port, err.message(), masterRank));
    }
    catch (const std::exception& err)
    {
        return finish(hemo::fluid_failed(port, err.what(), masterRank));
    }

    return finish(0);
}

// ************************************************************************* //
