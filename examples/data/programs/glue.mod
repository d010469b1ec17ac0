MODULE Glue
    ! A gluing path as RobotStudio writes a module: robtargets [[x,y,z] mm, [q1,q2,q3,q4] (q1 = w),
    ! [cf1,cf4,cf6,cfx], [external axes]], a tool and a work object, jointtargets in degrees.
    PERS tooldata tGlue:=[TRUE,[[0,0,150],[1,0,0,0]],[1.5,[0,0,60],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[900,-500,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    CONST jointtarget jHome:=[[0,-30,30,0,60,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    CONST robtarget pApproach:=[[100,200,150],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    CONST robtarget pStart:=[[100,200,20],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    CONST robtarget pVia:=[[200,300,20],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    CONST robtarget pEnd:=[[300,200,20],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];

    PROC main()
        MoveAbsJ jHome\NoEOffs, v1000, z50, tool0;
        MoveJ pApproach, v500, z20, tGlue\WObj:=wTable;
        MoveL pStart, v100, fine, tGlue\WObj:=wTable;
        MoveC pVia, pEnd, v50, z1, tGlue\WObj:=wTable;
        MoveL Offs(pEnd,0,0,100), v200, z20, tGlue\WObj:=wTable;
        MoveL [[150,250,120],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v200, z20, tGlue\WObj:=wTable;
        MoveAbsJ jHome\NoEOffs, v1000, fine, tool0;
    ENDPROC
ENDMODULE
